"""Test-only stand-ins for the ``rtde_control`` / ``rtde_receive`` modules of ur_rtde, with a fake controller.

They follow the real classes' method names and parameter names (``tests/robots/test_ur_rtde_backend.py``
checks that against the installed package), so the backend's calls can be checked without a robot:
what it sends, when it returns (``waitPeriod`` sleeps like the real one), how it reacts to a protective stop.
"""

from __future__ import annotations

import time as _time
import types
from dataclasses import dataclass, field
from datetime import timedelta
from typing import Any


@dataclass
class FakeController:
    """The robot side: state the receive interface reports, and every call the control interface got."""

    pose: list[float] = field(default_factory=lambda: [0.1, -0.4, 0.3, 0.0, 3.14159, 0.0])
    speed: list[float] = field(default_factory=lambda: [0.0] * 6)
    q: list[float] = field(default_factory=lambda: [0.0, -1.57, 1.57, -1.57, -1.57, 0.0])
    protective_stop: bool = False
    program_running: bool = True
    connected: bool = True
    timestamp: float = 12.5
    calls: list[tuple] = field(default_factory=list)

    def names(self) -> list[str]:
        return [call[0] for call in self.calls]


class FakeRTDEReceiveInterface:
    controller: FakeController

    def __init__(
        self,
        hostname: str,
        frequency: float = -1.0,
        variables: list[str] | None = None,
        verbose: bool = False,
        use_upper_range_registers: bool = False,
        rt_priority: int = 0,
    ) -> None:
        self.hostname, self.frequency = hostname, frequency
        self.controller.calls.append(("RTDEReceiveInterface", hostname, frequency))

    def getActualTCPPose(self) -> list[float]:
        return list(self.controller.pose)

    def getActualTCPSpeed(self) -> list[float]:
        return list(self.controller.speed)

    def getActualQ(self) -> list[float]:
        return list(self.controller.q)

    def isProtectiveStopped(self) -> bool:
        return self.controller.protective_stop

    def getTimestamp(self) -> float:
        return self.controller.timestamp

    def isConnected(self) -> bool:
        return self.controller.connected

    def disconnect(self) -> None:
        self.controller.calls.append(("receive.disconnect",))


class FakeRTDEControlInterface:
    controller: FakeController

    def __init__(
        self, hostname: str, frequency: float = -1.0, flags: int = 1, ur_cap_port: int = 50002, rt_priority: int = 0
    ) -> None:
        self.hostname, self.frequency = hostname, frequency
        self.controller.calls.append(("RTDEControlInterface", hostname, frequency))

    def speedL(self, xd: list[float], acceleration: float = 0.25, time: float = 0.0) -> bool:
        self.controller.calls.append(("speedL", list(xd), acceleration, time, _time.monotonic()))
        return not self.controller.protective_stop

    def speedStop(self, a: float = 10.0) -> bool:
        self.controller.calls.append(("speedStop", a))
        return True

    def moveL(
        self, pose: list[float], speed: float = 0.25, acceleration: float = 1.2, asynchronous: bool = False
    ) -> bool:
        self.controller.calls.append(("moveL", list(pose), speed, acceleration))
        self.controller.pose = list(pose)
        return not self.controller.protective_stop

    def initPeriod(self) -> timedelta:
        return timedelta(seconds=_time.monotonic())

    def waitPeriod(self, arg0: timedelta) -> None:
        step = 1.0 / (self.frequency if self.frequency > 0 else 500.0)
        remaining = arg0.total_seconds() + step - _time.monotonic()
        if remaining > 0:
            _time.sleep(remaining)

    def isProgramRunning(self) -> bool:
        return self.controller.program_running

    def reuploadScript(self) -> bool:
        self.controller.calls.append(("reuploadScript",))
        self.controller.program_running = True
        return True

    def setTcp(self, arg0: list[float]) -> bool:
        self.controller.calls.append(("setTcp", list(arg0)))
        return True

    def stopScript(self) -> None:
        self.controller.calls.append(("stopScript",))
        self.controller.program_running = False

    def disconnect(self) -> None:
        self.controller.calls.append(("control.disconnect",))


def fake_modules(controller: FakeController) -> tuple[types.ModuleType, types.ModuleType]:
    """``(rtde_control, rtde_receive)`` module objects whose interfaces talk to ``controller``."""
    control: Any = types.ModuleType("rtde_control")  # Any: the checker takes a module's attributes as fixed
    receive: Any = types.ModuleType("rtde_receive")
    control.RTDEControlInterface = type("RTDEControlInterface", (FakeRTDEControlInterface,), {"controller": controller})
    receive.RTDEReceiveInterface = type("RTDEReceiveInterface", (FakeRTDEReceiveInterface,), {"controller": controller})
    return control, receive
