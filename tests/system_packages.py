"""Debian programs some tests need (a browser, a virtual screen): found on PATH, or installed when possible.

Installing needs root and apt-get (CI runs as root); elsewhere, or without a network, the test is skipped
with the command that installs the program.
"""

from __future__ import annotations

import os
import shutil
import subprocess

import pytest


def find_or_install(binary: str, package: str) -> str:
    """Path of ``binary``; installs Debian's ``package`` if it is missing and that is possible, else skips."""
    path = shutil.which(binary)
    if path:
        return path
    install = f"apt-get install -y {package}"
    if not hasattr(os, "geteuid") or os.geteuid() != 0 or shutil.which("apt-get") is None:
        pytest.skip(f"{binary} not installed and cannot install it here (not root / no apt-get): run `{install}`")
    env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    proc = None
    for cmd in (["apt-get", "install", "-y", package], ["apt-get", "update"], ["apt-get", "install", "-y", package]):
        proc = subprocess.run(cmd, check=False, env=env, capture_output=True, text=True, timeout=900)
        if cmd[1] == "install" and proc.returncode == 0:
            break
    path = shutil.which(binary)
    if not path:
        detail = proc.stderr.strip()[-300:] if proc is not None else ""
        pytest.skip(f"{binary} not installed and `{install}` failed (no network?): {detail}")
    return path
