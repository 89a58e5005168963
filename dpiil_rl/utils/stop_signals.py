"""Turn the signals that stop a job into a clean pause of the run.

A batch system (SLURM, ``make paper`` killed at the end of a session) stops a job with SIGTERM; joblib's
loky worker processes ignore SIGINT, so Ctrl-C does not reach a run of ``make paper``. Inside
:func:`stop_signals_pause`, SIGTERM, SIGINT and SIGHUP raise :class:`KeyboardInterrupt` once in the main
thread: the trainer saves its ``pause`` checkpoint (every finished episode and its expert pairs), the
process exits with 128 + the signal's number (a sweep stops there), and the same command continues. Further
signals are ignored until the pause is written, so a second Ctrl-C cannot cut the checkpoint in half.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from types import FrameType
from typing import Iterator

STOP_SIGNALS = (signal.SIGTERM, signal.SIGINT, signal.SIGHUP)


class StopRequested(KeyboardInterrupt):
    """Raised in the main thread when a stop signal arrives (a KeyboardInterrupt: pauses the run).

    ``exit_code`` (128 + the signal's number, the shell's convention) is what the process should end
    with once the pause is saved, so a sweep of runs stops too instead of starting the next run."""

    def __init__(self, signum: int) -> None:
        super().__init__(f"stopped by {signal.Signals(signum).name}")
        self.signum = int(signum)
        self.exit_code = 128 + int(signum)


@contextlib.contextmanager
def stop_signals_pause() -> Iterator[None]:
    """Within the block, the first stop signal raises :class:`StopRequested`; later ones are ignored."""
    if threading.current_thread() is not threading.main_thread():
        yield  # signal handlers can only be installed from the main thread
        return

    def _stop(signum: int, frame: FrameType | None) -> None:
        del frame
        for sig in STOP_SIGNALS:
            signal.signal(sig, signal.SIG_IGN)
        raise StopRequested(signum)

    previous = {sig: signal.signal(sig, _stop) for sig in STOP_SIGNALS}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def release_semaphores() -> None:
    """Unlink the named semaphores this process created (tqdm's and torchrl's multiprocessing locks)
    before an ``os._exit``, which skips the interpreter's exit handlers: otherwise the resource
    tracker warns about "leaked semaphore objects" after every paused run. Only multiprocessing's
    finalizers of exit priority ≥ 0 run (semaphore cleanup is priority 0); nothing else is torn down."""
    from multiprocessing import util

    # private, so not in typeshed's stubs; the public path is interpreter exit, which os._exit skips
    util._run_finalizers(0)  # noqa: SLF001  # pyright: ignore[reportAttributeAccessIssue]
