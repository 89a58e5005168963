"""Shared fixtures: configs loaded from the real config tree, and a helper that runs the entry scripts."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path
from typing import Any, cast

import pytest
import torch
from omegaconf import DictConfig, OmegaConf

ROOT = Path(__file__).resolve().parents[1]
torch.set_num_threads(1)


def load_config(path: Path | str) -> DictConfig:
    """``OmegaConf.load`` of a file of the config tree (a mapping at its top level)."""
    return cast(DictConfig, OmegaConf.load(path))


def plain(cfg: DictConfig, resolve: bool = False) -> dict[str, Any]:
    """``OmegaConf.to_container`` of a mapping node: plain dicts and lists."""
    return cast("dict[str, Any]", OmegaConf.to_container(cfg, resolve=resolve))


def merged(cfg: DictConfig, changes: dict[str, Any]) -> DictConfig:
    """``OmegaConf.merge(cfg, changes)`` of a mapping node."""
    return cast(DictConfig, OmegaConf.merge(cfg, changes))


@pytest.fixture
def aperture_cfg() -> DictConfig:
    return load_config(ROOT / "configs" / "env" / "aperture.yaml")


def run_script(script: str, *overrides: str, timeout: float = 300, check: bool = True) -> subprocess.CompletedProcess:
    """Run the command ``dpiil-<script>`` (``python -m dpiil_rl.cli.<script>``) with Hydra overrides in a subprocess,
    as a user would."""
    env = {**os.environ, "HYDRA_FULL_ERROR": "0", "WANDB_SILENT": "true"}
    proc = subprocess.run(
        [sys.executable, "-m", f"dpiil_rl.cli.{script}", *overrides],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout,
    )
    if check and proc.returncode != 0:
        raise AssertionError(
            f"{script} {overrides} failed ({proc.returncode}):\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
        )
    return proc


def smoke_overrides(run_dir: Path, *extra: str) -> list[str]:
    return ["experiment=smoke", f"hydra.run.dir={run_dir}", *extra]
