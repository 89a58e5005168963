"""The robot interface every arm backend implements: the real UR5e (``ur_rtde``) or a simulated one.

Tasks that run on a real arm (``shaft``, ``ring_real``) and the UR5e teleoperation expert only talk to
this interface, so the same env, expert source and collector run against a robot or a simulation
(choose ``robot.backend`` in the config). Units: metres, seconds, radians; positions and velocities of
the tool centre point (TCP) are in the robot's base frame.

One control period is the unit of time: :meth:`RobotBackend.command_tcp_velocity` holds a velocity for
one period (a real robot keeps the pace with the controller's clock; a simulation advances by one
period), so a loop over it runs at the control rate.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from dpiil_rl.utils.connectable import Connectable
from dpiil_rl.utils.errors import RobotUnavailable  # noqa: F401  (raised here, defined at the bottom layer)


@dataclass(frozen=True)
class RobotState:
    """One reading of the arm."""

    tcp_position: np.ndarray  # (3,) m
    tcp_quaternion: np.ndarray  # (4,) w, x, y, z
    tcp_velocity: np.ndarray  # (3,) m/s, linear
    joint_positions: np.ndarray  # (6,) rad
    protective_stop: bool = False  # the controller stopped the arm (contact, limit); needs an unlock
    collision: bool = False  # the arm or what it holds touches an obstacle (simulation: MuJoCo contacts)
    time: float = 0.0  # s, the backend's clock (robot controller or simulation)


class RobotBackend(Connectable, ABC):
    """A 6-axis arm commanded by TCP velocity at a fixed control period."""

    #: seconds per control period (1 / control rate)
    control_period: float = 0.05

    def __init__(self) -> None:
        self._connected = False

    # ---------------------------------------------------------------------------- state and motion
    @abstractmethod
    def read_state(self) -> RobotState:
        """The arm's current state."""

    @abstractmethod
    def command_tcp_velocity(self, velocity: np.ndarray, acceleration: float) -> None:
        """Move the TCP at ``velocity`` (3,) m/s, orientation held, for one control period.

        ``acceleration`` (m/s^2) bounds how fast the arm may change its velocity. Callers are expected to
        pass commands through :class:`~dpiil_rl.robots.safety.SafetyFilter` first.
        """

    @abstractmethod
    def stop(self, deceleration: float) -> None:
        """Bring the TCP to rest at ``deceleration`` (m/s^2) and hold."""

    @abstractmethod
    def move_to(self, tcp_position: np.ndarray, speed: float) -> None:
        """Move the TCP to ``tcp_position`` (3,) in a straight line at ``speed`` (m/s), orientation held; blocks.

        Used between episodes (a start pose); never while a person or a policy is in control.
        """
