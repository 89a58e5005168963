"""The numbers the safety layer enforces on a real (or simulated) arm, checked once when they are built.

A wrong limit is worse than no limit: it gives a false sense of safety. So :class:`SafetyLimits` refuses
anything that cannot be enforced (an empty box, a zero or negative speed, NaN) with a message that names
the value and what was expected. Units: metres, seconds, the robot's base frame (``configs/safety/``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


def _box_corner(name: str, value: Sequence[float] | np.ndarray) -> np.ndarray:
    try:
        array = np.array([float(x) for x in value], dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"safety limit {name}={value!r}: expected 3 numbers (x, y, z in metres)") from exc
    if array.shape != (3,):
        raise ValueError(f"safety limit {name}={value!r}: expected 3 numbers (x, y, z in metres), got {array.size}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"safety limit {name}={array.tolist()}: expected finite numbers (metres)")
    return array


def _positive(name: str, value: float, unit: str) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"safety limit {name}={value!r}: expected a positive number ({unit})") from exc
    if not math.isfinite(number) or number <= 0.0:
        raise ValueError(f"safety limit {name}={value!r}: expected a finite number > 0 ({unit})")
    return number


@dataclass(frozen=True, eq=False)  # arrays inside: compare with to_dict()
class SafetyLimits:
    """Workspace box and motion limits of the tool centre point (TCP), validated on construction."""

    low: np.ndarray  # (3,) m, lower corner of the allowed TCP box (base frame)
    high: np.ndarray  # (3,) m, upper corner; every component > low's
    max_speed: float = 0.25  # m/s, bound on the TCP's linear speed |v|
    max_acceleration: float = 1.0  # m/s^2, bound on |v_k - v_(k-1)| / dt (and the braking deceleration)
    max_tracking_error: float = 0.05  # m, |target - TCP| above this is a protective stop
    watchdog_timeout: float = 0.1  # s, input older than this stops the arm

    def __post_init__(self) -> None:
        low = _box_corner("low", self.low)
        high = _box_corner("high", self.high)
        if not np.all(low < high):
            bad = [axis for axis, lo, hi in zip("xyz", low, high) if not lo < hi]
            raise ValueError(
                f"safety limits: workspace box low={low.tolist()} high={high.tolist()}: expected low < high on "
                f"every axis, not on {', '.join(bad)}"
            )
        low.setflags(write=False)
        high.setflags(write=False)
        object.__setattr__(self, "low", low)
        object.__setattr__(self, "high", high)
        object.__setattr__(self, "max_speed", _positive("max_speed", self.max_speed, "m/s"))
        object.__setattr__(self, "max_acceleration", _positive("max_acceleration", self.max_acceleration, "m/s^2"))
        object.__setattr__(self, "max_tracking_error", _positive("max_tracking_error", self.max_tracking_error, "m"))
        object.__setattr__(self, "watchdog_timeout", _positive("watchdog_timeout", self.watchdog_timeout, "s"))

    def contains(self, position: ArrayLike) -> bool:
        """True when ``position`` (3,) lies in the box (walls included)."""
        p = np.asarray(position, dtype=np.float64)
        return bool(np.all(np.isfinite(p)) and np.all(p >= self.low) and np.all(p <= self.high))

    def clamp(self, position: ArrayLike) -> np.ndarray:
        """The point of the box nearest to ``position`` (3,)."""
        return np.clip(np.asarray(position, dtype=np.float64), self.low, self.high)

    def to_dict(self) -> dict[str, Any]:
        """Plain numbers, for the run's config record and the safety log."""
        return {
            "low": self.low.tolist(),
            "high": self.high.tolist(),
            "max_speed": self.max_speed,
            "max_acceleration": self.max_acceleration,
            "max_tracking_error": self.max_tracking_error,
            "watchdog_timeout": self.watchdog_timeout,
        }
