"""The velocity filter between whoever commands the arm (a person, a policy) and the arm.

:meth:`SafetyFilter.filter` turns any command into one the arm may execute for one control period:

* **speed**: ``|v| <= max_speed``;
* **workspace**: from a TCP position ``p`` inside the box, ``p + v*dt`` stays inside, and along each axis
  the velocity toward a wall is small enough to stop before that wall at the braking deceleration
  (braking distance ``v**2 / (2a) <= distance``); from outside the box, an axis on which the TCP is out only
  allows motion back toward the box;
* **acceleration**: ``|v - v_prev| <= max_acceleration * dt``, ``v_prev`` being the previous output;
* **non-finite** commands (NaN, inf) are replaced by zero (a stop, ramped like any other command) and logged;
  a non-finite TCP reading gives a zero command at once (the arm's position is unknown).

Precedence, the one rule: **the workspace and the speed limit win over the acceleration limit.** The
acceleration bound yields only when the previous command already moves toward a wall faster than the arm
could stop from where it now is; the filter then brakes harder than ``max_acceleration``. The braking bounds
are built so that this does not happen in a steady loop: each axis brakes at ``max_acceleration / sqrt(3)``
(three axes braking at once stay within the bound), and the bound is exact in discrete time (the bound at
the next position is at most one step of braking below the current one). It can happen when the arm
does not go where it was sent (tracking lag, a changed ``dt``, a reset with a fast velocity, a TCP outside
the box).

A tracking error (:meth:`SafetyFilter.check_tracking`) latches a stop: the filter then commands zero
(ramped) until :meth:`SafetyFilter.reset`, which the person triggers by re-synchronising.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from dpiil_rl.robots.interface import RobotState
from dpiil_rl.robots.safety_limits import SafetyLimits
from dpiil_rl.robots.safety_log import SafetyEventKind, SafetyLog

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

#: m, kept between the TCP's next position and a wall, so that rounding never puts it outside
WALL_MARGIN = 1e-9
#: m/s, changes smaller than this are rounding, not clipping (no event)
_TOLERANCE = 1e-12


def braking_distance(speed: float, deceleration: float, dt: float) -> float:
    """Distance (m) covered from ``speed`` when each step of ``dt`` lowers the speed by ``deceleration*dt``.

    ``dt * (u + (u - m) + (u - 2m) + ...)`` with ``m = deceleration*dt``, the positive terms only; it is at
    least the continuous braking distance ``u**2 / (2 * deceleration)``.
    """
    if speed <= 0.0:
        return 0.0
    m = deceleration * dt
    n = math.floor(speed / m)
    return dt * (n + 1) * (speed - m * n / 2.0)


def braking_speed(distance: float, deceleration: float, dt: float, cap: float) -> float:
    """The largest speed (m/s, at most ``cap``) whose :func:`braking_distance` fits in ``distance`` (m).

    Exact inverse of :func:`braking_distance` (piecewise linear in the speed), so that a speed at the bound
    here, after one step of ``dt``, is at most one step of braking above the bound at the new distance.
    """
    if not distance > 0.0:
        return 0.0
    if braking_distance(cap, deceleration, dt) <= distance:
        return cap
    m = deceleration * dt
    x = distance / (dt * m)  # n (n + 1) / 2 <= x
    n = max(int((math.sqrt(8.0 * x + 1.0) - 1.0) / 2.0), 0)
    while dt * m * (n + 1) * (n + 2) / 2.0 <= distance:
        n += 1
    while n > 0 and dt * m * n * (n + 1) / 2.0 > distance:
        n -= 1
    return min(distance / (dt * (n + 1)) + m * n / 2.0, cap)


def _norm(v: np.ndarray) -> float:
    """Euclidean norm of a (3,) vector; ``math.hypot`` does not overflow for huge finite components."""
    return math.hypot(*v.tolist())


def _clip_norm(v: np.ndarray, max_norm: float) -> np.ndarray:
    """``v`` (finite) scaled down to norm ``max_norm`` if longer, direction kept."""
    norm = _norm(v)
    if norm <= max_norm:
        return v
    return v * (max_norm / norm)


class SafetyFilter:
    """Enforces :class:`~dpiil_rl.robots.safety_limits.SafetyLimits` on TCP velocity commands."""

    def __init__(self, limits: SafetyLimits, log: SafetyLog | None = None) -> None:
        self.limits = limits
        self.log = log if log is not None else SafetyLog()
        #: per-axis braking deceleration (m/s^2): three axes braking together stay within max_acceleration
        self.braking_deceleration = limits.max_acceleration / math.sqrt(3.0)
        self._wall_low: list[float] = limits.low.tolist()
        self._wall_high: list[float] = limits.high.tolist()
        self._previous = np.zeros(3)
        self._stopped = False

    # ---------------------------------------------------------------------------- state
    @property
    def previous(self) -> np.ndarray:
        """The last velocity this filter allowed (m/s); the acceleration bound is taken from it."""
        return self._previous.copy()

    @property
    def stopped(self) -> bool:
        """True while a stop is latched (tracking error); cleared by :meth:`reset`."""
        return self._stopped

    def reset(self, velocity: ArrayLike | None = None) -> None:
        """Forget the previous command and clear a latched stop (the person re-synchronised).

        The next command ramps from ``velocity`` (m/s; default zero, the arm at rest; clipped to the speed
        limit). After a stop or a ``move_to`` that should not clear a latched stop, use :meth:`note_at_rest`.
        """
        if self._stopped:
            self.log.record(SafetyEventKind.STOP_CLEARED)
        self._stopped = False
        previous = np.zeros(3) if velocity is None else np.asarray(velocity, dtype=np.float64).reshape(3)
        if not np.isfinite(previous).all():
            previous = np.zeros(3)
        self._previous = _clip_norm(previous, self.limits.max_speed)

    def note_at_rest(self) -> None:
        """The arm was brought to rest by other means (a stop, ``move_to``): the next command ramps from zero.

        Unlike :meth:`reset`, a latched stop stays latched.
        """
        self._previous = np.zeros(3)

    # ---------------------------------------------------------------------------- the bounds
    def velocity_bounds(self, position: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Per-axis interval ``[low, high]`` (m/s) the velocity must lie in at ``position`` (3,).

        Always ``low <= 0 <= high``: stopping is always allowed.
        """
        p = np.asarray(position, dtype=np.float64).tolist()
        wall_low, wall_high = self._wall_low, self._wall_high
        a, cap = self.braking_deceleration, self.limits.max_speed
        low, high = [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]
        for axis in range(3):
            to_high = wall_high[axis] - p[axis]
            to_low = p[axis] - wall_low[axis]
            if to_high > 0.0:
                high[axis] = braking_speed(to_high - WALL_MARGIN, a, dt, cap)
            if to_low > 0.0:
                low[axis] = -braking_speed(to_low - WALL_MARGIN, a, dt, cap)
        return np.array(low), np.array(high)

    # ---------------------------------------------------------------------------- filtering
    def filter(self, velocity: ArrayLike, state: RobotState, dt: float) -> np.ndarray:
        """The velocity (3,) m/s the arm may hold for the next ``dt`` seconds, given ``velocity`` was asked."""
        dt = float(dt)
        if not math.isfinite(dt) or dt <= 0.0:
            raise ValueError(f"SafetyFilter.filter: dt={dt!r}: expected a finite control period > 0 (s)")
        command = np.asarray(velocity, dtype=np.float64).reshape(-1)
        if command.shape != (3,):
            raise ValueError(f"SafetyFilter.filter: velocity of shape {command.shape}: expected (3,) m/s")
        position = np.asarray(state.tcp_position, dtype=np.float64).reshape(-1)
        robot_time = float(state.time)
        if position.shape != (3,) or not np.isfinite(position).all():
            self.log.record(SafetyEventKind.NON_FINITE, robot_time, what="tcp_position", value=position)
            self._previous = np.zeros(3)
            return np.zeros(3)

        if self._stopped:
            desired = np.zeros(3)
        elif not np.isfinite(command).all():
            self.log.record(SafetyEventKind.NON_FINITE, robot_time, what="velocity", value=command)
            desired = np.zeros(3)
        else:
            desired = command.copy()

        speed = _norm(desired)
        if speed > self.limits.max_speed:
            desired = _clip_norm(desired, self.limits.max_speed)
            self.log.record(SafetyEventKind.SPEED_CLIPPED, robot_time, requested=speed, allowed=self.limits.max_speed)

        low, high = self.velocity_bounds(position, dt)
        target = np.minimum(np.maximum(desired, low), high)  # toward a wall: no faster than one can stop from
        base = np.minimum(np.maximum(self._previous, low), high)  # braking the previous command needs, if any
        braking = _norm(base - self._previous)
        budget = max(self.limits.max_acceleration * dt - braking, 0.0)
        step = target - base
        step_size = _norm(step)
        allowed = base + step * (budget / step_size) if step_size > budget else target

        if _norm(target - desired) > _TOLERANCE or braking > _TOLERANCE:
            self.log.record(
                SafetyEventKind.WORKSPACE_CLIPPED,
                robot_time,
                position=position,
                requested=desired,
                allowed=allowed,
                braking=braking > _TOLERANCE,
                beyond_acceleration=braking > self.limits.max_acceleration * dt + _TOLERANCE,
            )
        if step_size > budget + _TOLERANCE:
            self.log.record(
                SafetyEventKind.ACCEL_CLIPPED,
                robot_time,
                requested=target,
                allowed=allowed,
                requested_acceleration=(_norm(target - self._previous) / dt),
            )
        self._previous = allowed
        return allowed.copy()

    # ---------------------------------------------------------------------------- tracking
    def check_tracking(self, target: ArrayLike, state: RobotState) -> bool:
        """True while the TCP is within ``max_tracking_error`` of ``target`` (3,) and no stop is latched.

        A larger error (or a non-finite target or reading) records an event and latches a stop: from then on
        :meth:`filter` commands zero until :meth:`reset`.
        """
        goal = np.asarray(target, dtype=np.float64).reshape(-1)
        position = np.asarray(state.tcp_position, dtype=np.float64).reshape(-1)
        robot_time = float(state.time)
        if goal.shape != (3,) or position.shape != (3,):
            raise ValueError(
                f"SafetyFilter.check_tracking: target {goal.shape}, TCP {position.shape}: expected (3,) each"
            )
        if not (np.isfinite(goal).all() and np.isfinite(position).all()):
            if not self._stopped:
                self.log.record(SafetyEventKind.NON_FINITE, robot_time, what="tracking", target=goal, position=position)
                self._stopped = True
            return False
        error = _norm(goal - position)
        if error > self.limits.max_tracking_error:
            if not self._stopped:
                self.log.record(
                    SafetyEventKind.TRACKING_ERROR,
                    robot_time,
                    error=error,
                    limit=self.limits.max_tracking_error,
                    target=goal,
                    position=position,
                )
                self._stopped = True
            return False
        return not self._stopped
