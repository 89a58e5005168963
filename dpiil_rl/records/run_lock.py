"""One process at a time in a run directory.

Two processes training the same run (a study started twice, or a worker left over from a stopped launch)
would both append to its records, and its ``episodes.jsonl`` would hold every episode twice. ``hold_run_dir``
takes an exclusive, non-blocking ``flock`` on ``<run_dir>/.lock`` for the rest of the process's life; the
operating system drops it when the process ends, however it ends, so a killed run leaves no stale lock. A
process may hold many runs (lockstep batches) and take the same one again (a resume in the same process).
"""

from __future__ import annotations

import fcntl
import os
from pathlib import Path
from typing import IO

_HELD: dict[str, IO[str]] = {}


class RunDirInUse(ValueError):
    """Another process is training this run."""


def hold_run_dir(run_dir: str | Path) -> None:
    """Take ``run_dir``'s lock, or raise :class:`RunDirInUse` naming the process that holds it."""
    run_dir = Path(run_dir)
    key = str(run_dir.resolve())
    if key in _HELD:
        return
    run_dir.mkdir(parents=True, exist_ok=True)
    handle = open(run_dir / ".lock", "a+")  # noqa: SIM115 (kept open: the lock lives as long as the file)
    try:
        fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        handle.seek(0)
        holder = handle.read().strip() or "another process"
        handle.close()
        raise RunDirInUse(
            f"run_dir = {str(run_dir)!r}: in use by pid {holder}; expected one process per run "
            "(wait for it to finish, or stop it: its records resume from the last checkpoint)"
        ) from None
    handle.seek(0)
    handle.truncate()
    handle.write(str(os.getpid()))
    handle.flush()
    _HELD[key] = handle
