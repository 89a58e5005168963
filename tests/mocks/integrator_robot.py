"""Test-only robot backend: a point TCP that holds each commanded velocity for one period (exact integration).

It records every call, so tests can check what the safety layer let through; ``protective_stop`` can be
set to play a controller that stopped the arm.
"""

from __future__ import annotations

import numpy as np

from dpiil_rl.robots.interface import RobotBackend, RobotState


class IntegratorRobot(RobotBackend):
    def __init__(self, position: np.ndarray | list[float], control_period: float = 0.05) -> None:
        super().__init__()
        self.control_period = control_period
        self.position = np.asarray(position, dtype=np.float64).copy()
        self.velocity = np.zeros(3)
        self.time = 0.0
        self.protective_stop = False
        self.commands: list[tuple[np.ndarray, float]] = []  # (velocity, acceleration) per command
        self.stops: list[float] = []  # deceleration per stop
        self.moves: list[tuple[np.ndarray, float]] = []  # (target, speed) per move_to

    def read_state(self) -> RobotState:
        return RobotState(
            tcp_position=self.position.copy(),
            tcp_quaternion=np.array([1.0, 0.0, 0.0, 0.0]),
            tcp_velocity=self.velocity.copy(),
            joint_positions=np.zeros(6),
            protective_stop=self.protective_stop,
            time=self.time,
        )

    def command_tcp_velocity(self, velocity: np.ndarray, acceleration: float) -> None:
        v = np.asarray(velocity, dtype=np.float64).copy()
        self.commands.append((v, float(acceleration)))
        self.velocity = v
        self.position = self.position + v * self.control_period
        self.time += self.control_period

    def stop(self, deceleration: float) -> None:
        self.stops.append(float(deceleration))
        self.velocity = np.zeros(3)

    def move_to(self, tcp_position: np.ndarray, speed: float) -> None:
        target = np.asarray(tcp_position, dtype=np.float64).copy()
        self.moves.append((target, float(speed)))
        self.position = target
        self.velocity = np.zeros(3)
