"""The safety layer of the real-robot path, in one import.

``SafetyLimits`` (the numbers, ``configs/safety/``) → ``SafetyFilter`` (what one velocity command may be)
→ ``SafeRobot`` (a backend wrapper that applies the filter to every command and refuses motion during a
stop); ``SafetyLog`` records every event in ``<run dir>/safety_events.jsonl``; ``Watchdog`` checks the
freshness of an input stream on the teleoperation side. Each lives in its own ``safety_*`` module.
"""

from __future__ import annotations

from dpiil_rl.robots.safety_filter import SafetyFilter, braking_distance, braking_speed
from dpiil_rl.robots.safety_limits import SafetyLimits
from dpiil_rl.robots.safety_log import (
    EVENTS_FILE,
    SafetyEvent,
    SafetyEventKind,
    SafetyLog,
)
from dpiil_rl.robots.safety_robot import SafeRobot, SafetyRefusal
from dpiil_rl.robots.safety_watchdog import Watchdog

__all__ = [
    "EVENTS_FILE",
    "SafeRobot",
    "SafetyEvent",
    "SafetyEventKind",
    "SafetyFilter",
    "SafetyLimits",
    "SafetyLog",
    "SafetyRefusal",
    "Watchdog",
    "braking_distance",
    "braking_speed",
]
