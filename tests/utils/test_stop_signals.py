"""Stop signals become one KeyboardInterrupt (the trainer's pause), then are ignored until the block ends."""

from __future__ import annotations

import os
import signal
import threading

import pytest

from dpiil_rl.utils.stop_signals import STOP_SIGNALS, StopRequested, stop_signals_pause


@pytest.mark.parametrize("sig", STOP_SIGNALS, ids=lambda s: signal.Signals(s).name)
def test_first_signal_raises_later_ones_are_ignored(sig: int) -> None:
    before = signal.getsignal(sig)
    with pytest.raises(StopRequested, match=signal.Signals(sig).name) as stopped:
        with stop_signals_pause():
            os.kill(os.getpid(), sig)
            pytest.fail("the signal did not interrupt the block")
    assert stopped.value.exit_code == 128 + sig
    assert signal.getsignal(sig) == before  # restored


def test_a_second_signal_during_the_pause_is_ignored() -> None:
    saved = []
    with pytest.raises(StopRequested):
        with stop_signals_pause():
            try:
                os.kill(os.getpid(), signal.SIGTERM)
            except StopRequested:
                os.kill(os.getpid(), signal.SIGTERM)  # the pause is being written: must not interrupt it
                saved.append(True)
                raise
    assert saved == [True]


def test_signals_a_worker_ignores_are_honoured_inside_and_ignored_again_after() -> None:
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)  # as in a joblib (loky) worker process
    try:
        with pytest.raises(StopRequested, match="SIGINT"):
            with stop_signals_pause():
                os.kill(os.getpid(), signal.SIGINT)
        assert signal.getsignal(signal.SIGINT) == signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, previous)


def test_outside_the_main_thread_it_installs_nothing() -> None:
    seen = []

    def body() -> None:
        with stop_signals_pause():
            seen.append(signal.getsignal(signal.SIGTERM))

    before = signal.getsignal(signal.SIGTERM)
    thread = threading.Thread(target=body)
    thread.start()
    thread.join()
    assert seen == [before]
