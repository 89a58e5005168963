"""A robot backend that only lets safe motion through: the one the tasks and the teleoperation drive.

:class:`SafeRobot` wraps any :class:`~dpiil_rl.robots.interface.RobotBackend` (the real UR5e or a
simulation) and is one itself, so env, expert and collector code cannot bypass the safety layer by
accident: every velocity command goes through :class:`~dpiil_rl.robots.safety_filter.SafetyFilter`, start
poses are moved into the workspace box at no more than the speed limit, and while the controller reports
a protective stop (or the filter has latched a tracking stop) motion is refused: the arm is told to stop
and the refusal is logged.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from dpiil_rl.robots.interface import RobotBackend, RobotState
from dpiil_rl.robots.safety_filter import SafetyFilter
from dpiil_rl.robots.safety_limits import SafetyLimits
from dpiil_rl.robots.safety_log import SafetyEventKind, SafetyLog

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


class SafetyRefusal(RuntimeError):
    """The safety layer refused a blocking motion (``move_to``); the message says why."""


class SafeRobot(RobotBackend):
    """``backend`` behind the safety limits; events go to ``log``."""

    def __init__(self, backend: RobotBackend, limits: SafetyLimits, log: SafetyLog | None = None) -> None:
        super().__init__()
        self.backend = backend
        self.limits = limits
        self.log = log if log is not None else SafetyLog()
        self.filter = SafetyFilter(limits, self.log)
        self.control_period = backend.control_period

    # ---------------------------------------------------------------------------- lifecycle
    def connect(self) -> None:
        self.backend.connect()
        self.control_period = self.backend.control_period
        self.filter.note_at_rest()

    def disconnect(self) -> None:
        self.backend.disconnect()

    @property
    def is_connected(self) -> bool:
        return self.backend.is_connected

    # ---------------------------------------------------------------------------- state and motion
    def read_state(self) -> RobotState:
        return self.backend.read_state()

    def command_tcp_velocity(self, velocity: np.ndarray, acceleration: float) -> None:
        """Filter ``velocity`` and hold it for one period; refused (the arm stops) while a stop is active.

        The backend gets the caller's ``acceleration`` capped at ``max_acceleration``, raised where the
        filter brakes harder (so the arm does reach the braking command within the period).
        """
        state = self.backend.read_state()
        if state.protective_stop or self.filter.stopped:
            self._refuse(state, "command_tcp_velocity")
            return
        dt = self.backend.control_period
        previous = self.filter.previous
        allowed = self.filter.filter(velocity, state, dt)
        requested = float(acceleration)
        if not math.isfinite(requested) or requested <= 0.0:
            requested = self.limits.max_acceleration
        needed = float(np.linalg.norm(allowed - previous)) / dt
        self.backend.command_tcp_velocity(allowed, max(min(requested, self.limits.max_acceleration), needed))

    def stop(self, deceleration: float) -> None:
        """Stop at ``deceleration``, never gentler than ``max_acceleration`` (the braking the box assumes)."""
        rate = float(deceleration)
        if not math.isfinite(rate):
            rate = self.limits.max_acceleration
        self.backend.stop(max(rate, self.limits.max_acceleration))
        self.filter.note_at_rest()

    def move_to(self, tcp_position: ArrayLike, speed: float) -> None:
        """Move to ``tcp_position`` clamped into the box, at no more than ``max_speed``; blocks.

        Raises :class:`SafetyRefusal` (after logging) while a stop is active or for a non-finite target or
        speed. A straight line to a point of the (convex) box never leaves it, and from outside it only
        gets closer.
        """
        state = self.backend.read_state()
        if state.protective_stop or self.filter.stopped:
            self._refuse(state, "move_to")
            raise SafetyRefusal(
                "move_to refused: the arm is in a protective stop (unlock it on the teach pendant)"
                if state.protective_stop
                else "move_to refused: a tracking-error stop is latched (re-synchronise to clear it)"
            )
        target = np.asarray(tcp_position, dtype=np.float64).reshape(-1)
        rate = float(speed)
        if target.shape != (3,) or not np.all(np.isfinite(target)) or not math.isfinite(rate) or rate <= 0.0:
            self.log.record(SafetyEventKind.NON_FINITE, state.time, what="move_to", target=target, speed=rate)
            raise SafetyRefusal(
                f"move_to refused: target {target.tolist()} at {rate} m/s; expected 3 finite coordinates (m) "
                "and a finite speed > 0 (m/s)"
            )
        inside = self.limits.clamp(target)
        if not np.array_equal(inside, target):
            self.log.record(
                SafetyEventKind.WORKSPACE_CLIPPED, state.time, what="move_to", requested=target, allowed=inside
            )
        if rate > self.limits.max_speed:
            self.log.record(
                SafetyEventKind.SPEED_CLIPPED, state.time, what="move_to", requested=rate, allowed=self.limits.max_speed
            )
            rate = self.limits.max_speed
        self.backend.move_to(inside, rate)
        self.filter.note_at_rest()

    # ---------------------------------------------------------------------------- tracking
    def check_tracking(self, target: np.ndarray) -> bool:
        """True while the TCP tracks ``target`` (3,); a tracking error stops the arm and latches the stop."""
        was_stopped = self.filter.stopped
        ok = self.filter.check_tracking(target, self.backend.read_state())
        if self.filter.stopped and not was_stopped:
            self.backend.stop(self.limits.max_acceleration)
            self.filter.note_at_rest()
        return ok

    @property
    def stopped(self) -> bool:
        """True while a tracking-error stop is latched."""
        return self.filter.stopped

    def reset(self) -> None:
        """Clear a latched stop (the person re-synchronised); the next command ramps from rest."""
        self.filter.reset()

    def _refuse(self, state: RobotState, what: str) -> None:
        reason = "controller protective stop" if state.protective_stop else "tracking-error stop latched"
        self.log.record(SafetyEventKind.PROTECTIVE_STOP, state.time, what=what, reason=reason)
        self.backend.stop(self.limits.max_acceleration)
        self.filter.note_at_rest()
