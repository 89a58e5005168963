"""``make sync``: upload offline wandb runs where a server is reachable; explain what to do where not.

Runs log offline (``<run_dir>/wandb/offline-run-*``) and never need a network. Syncing them is a
separate, optional step: this module finds the offline runs below a folder, checks that an API key
and the server (``WANDB_BASE_URL``, default https://api.wandb.ai) are there, and runs ``wandb sync``
on them. Without a key or a server it lists the runs, says how to sync later, and changes nothing.
"""

from __future__ import annotations

import netrc
import os
import shutil
import socket
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import urlparse

from dpiil_rl.loggers.wandb_offline import offline_runs

DEFAULT_BASE_URL = "https://api.wandb.ai"


@dataclass
class SyncPlan:
    runs: list[Path]
    base_url: str
    has_key: bool
    reachable: bool

    @property
    def can_sync(self) -> bool:
        return bool(self.runs) and self.has_key and self.reachable


def _has_key(host: str) -> bool:
    if os.environ.get("WANDB_API_KEY"):
        return True
    try:
        return netrc.netrc().authenticators(host) is not None
    except (FileNotFoundError, netrc.NetrcParseError):
        return False


def _reachable(host: str, port: int, timeout: float) -> bool:
    try:
        with socket.create_connection((host, port), timeout=timeout):
            return True
    except OSError:
        return False


def plan_sync(root: str | Path, timeout: float = 3.0) -> SyncPlan:
    root = Path(root)
    if not root.exists():
        raise FileNotFoundError(
            f"RUNS = {str(root)!r}: no such folder (expected a run directory or a folder of runs, e.g. runs/)"
        )
    base_url = os.environ.get("WANDB_BASE_URL", DEFAULT_BASE_URL)
    url = urlparse(base_url)
    host = url.hostname or ""
    port = url.port or (443 if url.scheme == "https" else 80)
    runs = offline_runs(root)
    return SyncPlan(runs, base_url, _has_key(host), bool(host) and _reachable(host, port, timeout))


def sync(root: str | Path, dry_run: bool = False) -> int:
    plan = plan_sync(root)
    print(f"{len(plan.runs)} offline wandb run(s) under {root}")
    if not plan.runs:
        return 0
    if dry_run or not plan.can_sync:
        if not plan.has_key:
            print(
                f"no API key for {plan.base_url}: set WANDB_API_KEY or run `.venv/bin/wandb login` "
                "(or `wandb login --host <url>`)"
            )
        if not plan.reachable:
            print(
                f"server {plan.base_url} not reachable from here: sync later from a machine that reaches it, "
                "or set WANDB_BASE_URL to your own wandb server"
            )
        print(
            "nothing uploaded; the runs stay in their run directories. Once a server is reachable: make sync RUNS="
            + str(root)
        )
        return 0
    wandb_cli = shutil.which("wandb", path=str(Path(sys.executable).parent)) or "wandb"
    proc = subprocess.run([wandb_cli, "sync", *map(str, plan.runs)])
    return proc.returncode
