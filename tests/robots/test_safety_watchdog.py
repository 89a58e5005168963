"""Watchdog: stale or missing input counts as expired; one event per expiry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from dpiil_rl.robots.safety_limits import SafetyLimits
from dpiil_rl.robots.safety_log import SafetyEventKind, SafetyLog
from dpiil_rl.robots.safety_watchdog import Watchdog


def test_expires_after_the_timeout_and_recovers_when_fed() -> None:
    log = SafetyLog()
    dog = Watchdog(0.125, log, name="mocap")  # binary-exact numbers: the boundary is tested exactly
    assert dog.expired(0.0)  # never fed: not fresh
    assert log.count(SafetyEventKind.WATCHDOG) == 0
    dog.feed(1.0)
    assert not dog.expired(1.0625) and not dog.expired(1.125)
    assert dog.expired(1.126)
    assert dog.expired(1.5) and dog.expired(2.0)  # still expired: one event for this expiry
    assert log.count(SafetyEventKind.WATCHDOG) == 1
    event = log.events[-1]
    assert event.details["source"] == "mocap" and event.details["age"] == pytest.approx(0.126)
    dog.feed(2.0)
    assert not dog.expired(2.01)
    assert dog.expired(2.25)
    assert log.count(SafetyEventKind.WATCHDOG) == 2


def test_old_or_non_finite_stamps_do_not_refresh() -> None:
    dog = Watchdog(0.1)
    dog.feed(5.0)
    dog.feed(4.0)
    dog.feed(math.nan)
    dog.feed(math.inf)
    assert dog.last_feed == 5.0
    assert dog.expired(5.2)
    assert dog.expired(math.nan)  # an unknown "now" is not fresh either
    dog.reset()
    assert dog.last_feed is None and dog.expired(5.0)


def test_timeout_comes_from_the_limits_and_must_be_positive() -> None:
    limits = SafetyLimits(low=np.zeros(3), high=np.ones(3), watchdog_timeout=0.25)
    assert Watchdog.from_limits(limits).timeout == 0.25
    for bad in (0.0, -1.0, math.nan):
        with pytest.raises(ValueError, match="Watchdog timeout"):
            Watchdog(bad)
