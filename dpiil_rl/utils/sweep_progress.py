"""A progress bar over the runs of a Hydra multirun (``make paper``, ``make seeds``).

Registered as a Hydra callback in ``configs/config.yaml``. At the start of a multirun it counts the
jobs from the sweep overrides and starts a tqdm bar in the launching process; every job, wherever
the launcher runs it (joblib workers, submitit), appends one line to a small progress file when it
ends; the bar follows that file. Single runs are untouched.
"""

from __future__ import annotations

import os
import threading
from pathlib import Path
from typing import Any

from hydra.core.override_parser.overrides_parser import OverridesParser
from hydra.experimental.callback import Callback
from omegaconf import DictConfig
from tqdm import tqdm

ENV_VAR = "DPIIL_SWEEP_PROGRESS"


def count_jobs(overrides: list[str]) -> int:
    """Number of jobs a basic-sweeper multirun makes from ``overrides`` (product of the sweep sizes)."""
    total = 1
    for override in OverridesParser.create().parse_overrides(list(overrides)):
        if override.is_sweep_override():
            total *= len(list(override.sweep_iterator()))
    return total


def _alive(pid: str) -> bool:
    try:
        os.kill(int(pid), 0)
    except (ValueError, ProcessLookupError):
        return False
    except PermissionError:
        return True
    return True


class SweepProgress(Callback):
    def __init__(self, poll_s: float = 2.0) -> None:
        self.poll_s = float(poll_s)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._file: Path | None = None
        self._bar: tqdm | None = None

    # launchers ship the callbacks to their workers: only the settings travel, not the bar or thread
    def __getstate__(self) -> dict[str, Any]:
        return {"poll_s": self.poll_s}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__init__(**state)  # type: ignore[misc]

    # ------------------------------------------------------------------ launching process
    def on_multirun_start(self, config: DictConfig, **kwargs: Any) -> None:
        total = count_jobs(list(config.hydra.overrides.task))
        folder = Path(str(config.hydra.sweep.dir))
        folder.mkdir(parents=True, exist_ok=True)
        for stale in folder.glob(".sweep-progress-*"):  # left by a sweep that was killed
            if not _alive(stale.name.rsplit("-", 1)[-1]):
                stale.unlink(missing_ok=True)
        self._file = folder / f".sweep-progress-{os.getpid()}"
        self._file.write_text("")
        os.environ[ENV_VAR] = str(self._file)  # inherited by the launcher's workers
        self._bar = tqdm(total=total, desc="sweep", unit="run", dynamic_ncols=True)
        self._stop.clear()
        self._thread = threading.Thread(target=self._follow, daemon=True)
        self._thread.start()

    def on_multirun_end(self, config: DictConfig, **kwargs: Any) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)
        self._refresh()
        if self._bar is not None:
            self._bar.close()
        if self._file is not None:
            self._file.unlink(missing_ok=True)
        os.environ.pop(ENV_VAR, None)

    def _follow(self) -> None:
        while not self._stop.wait(self.poll_s):
            self._refresh()

    def _refresh(self) -> None:
        if self._bar is None or self._file is None or not self._file.exists():
            return
        lines = self._file.read_text().splitlines()
        if len(lines) > self._bar.n:
            self._bar.update(len(lines) - self._bar.n)
            self._bar.set_postfix_str(lines[-1][-60:])

    # ------------------------------------------------------------------ every job
    def on_job_end(self, config: DictConfig, job_return: Any, **kwargs: Any) -> None:
        path = os.environ.get(ENV_VAR)
        if not path:
            return
        status = getattr(getattr(job_return, "status", None), "name", "DONE")
        name = f"{config.env.name}/{config.get('run_name') or config.method.name}/seed_{config.seed}"
        with open(path, "a") as fh:  # one short line per job: appends do not interleave
            fh.write(f"{status} {name}\n")
