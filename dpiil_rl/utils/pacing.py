"""Real-time pacing of a control loop driven by a person: one step per control period."""

from __future__ import annotations

import time


class RealTimePacer:
    """``wait()`` sleeps until the next tick of a ``period``-second clock.

    A step that overran does not make the next ones shorter: the clock restarts from now when it fell
    more than one period behind (a person would see the robot lurch to catch up otherwise).
    """

    def __init__(self, period: float) -> None:
        if not period > 0:
            raise ValueError(f"control period = {period} s: expected a positive period")
        self.period = float(period)
        self._next: float | None = None

    def wait(self) -> None:
        now = time.monotonic()
        if self._next is None or now - self._next > self.period:
            self._next = now
        self._next += self.period
        delay = self._next - now
        if delay > 0:
            time.sleep(delay)
