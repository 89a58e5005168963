"""The code a run was made by, recorded in ``summary.json`` as ``code``: the package version, and when the
package is imported from a git checkout, the commit and whether its tracked files differ from that commit.

A results page names the commit of each run in its provenance; with this field the run says it itself.
Outside a git checkout (an installed wheel) ``commit`` and ``dirty`` are None.
"""

from __future__ import annotations

import subprocess
from functools import lru_cache
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

#: the checkout's root when the package is imported from one (the folder holding ``dpiil_rl/``)
_ROOT = Path(__file__).resolve().parents[2]


def _git(*args: str) -> str | None:
    try:
        done = subprocess.run(["git", "-C", str(_ROOT), *args], capture_output=True, text=True, timeout=10, check=False)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return done.stdout.strip() if done.returncode == 0 else None


@lru_cache(maxsize=1)
def code_version() -> dict[str, Any]:
    """``{"version": ..., "commit": <40 hex> | None, "dirty": bool | None}`` of the running ``dpiil_rl``."""
    try:
        package = version("dpiil_rl")
    except PackageNotFoundError:
        package = None
    inside = _git("rev-parse", "--show-toplevel")
    if inside is None or Path(inside).resolve() != _ROOT:
        return {"version": package, "commit": None, "dirty": None}
    commit = _git("rev-parse", "HEAD")
    changed = _git("status", "--porcelain", "--untracked-files=no", "--", "dpiil_rl")
    return {"version": package, "commit": commit, "dirty": None if changed is None else bool(changed)}
