"""Freshness of an input stream (motion capture, game pad): stale input must stop the arm.

A teleoperated arm follows the last hand pose it received. If the stream stalls (network, tracker lost the
markers, a frozen reader thread) the arm would keep following an old pose. :class:`Watchdog` answers "is
the newest sample recent enough?" on the input side; the teleoperation expert asks it every control step
and stops commanding motion when it has expired.
"""

from __future__ import annotations

import math

from dpiil_rl.robots.safety_limits import SafetyLimits
from dpiil_rl.robots.safety_log import SafetyEventKind, SafetyLog


class Watchdog:
    """Expires when the newest fed timestamp is more than ``timeout`` seconds older than ``now``.

    Timestamps and ``now`` must come from the same clock (e.g. ``time.monotonic()``). Before the first
    feed the watchdog counts as expired (no input is not fresh input). With a ``log``, each expiry of a fed
    stream records one ``WATCHDOG`` event (not one per step).
    """

    def __init__(self, timeout: float, log: SafetyLog | None = None, name: str = "input") -> None:
        timeout = float(timeout)
        if not math.isfinite(timeout) or timeout <= 0.0:
            raise ValueError(f"Watchdog timeout={timeout!r}: expected a finite number of seconds > 0")
        self.timeout = timeout
        self.log = log
        self.name = name
        self._last: float | None = None
        self._reported = False

    @classmethod
    def from_limits(cls, limits: SafetyLimits, log: SafetyLog | None = None, name: str = "input") -> Watchdog:
        return cls(limits.watchdog_timeout, log, name)

    @property
    def last_feed(self) -> float | None:
        """Timestamp of the newest sample, None before the first."""
        return self._last

    def feed(self, timestamp: float) -> None:
        """A sample stamped ``timestamp`` arrived. Older or non-finite stamps do not refresh the watchdog."""
        stamp = float(timestamp)
        if not math.isfinite(stamp):
            return
        if self._last is None or stamp > self._last:
            self._last = stamp
            self._reported = False

    def age(self, now: float) -> float:
        """Seconds since the newest sample (inf before the first)."""
        return math.inf if self._last is None else float(now) - self._last

    def expired(self, now: float) -> bool:
        """True when no sample is fresher than ``timeout`` at ``now`` (also for a non-finite ``now``)."""
        age = self.age(now)
        if not math.isfinite(float(now)):
            age = math.inf
        stale = age > self.timeout
        if stale and self._last is not None and not self._reported:
            self._reported = True
            if self.log is not None:
                self.log.record(SafetyEventKind.WATCHDOG, source=self.name, age=age, timeout=self.timeout)
        return stale

    def reset(self) -> None:
        """Forget all samples (a new session): expired until the next feed."""
        self._last = None
        self._reported = False
