"""The real UR5e, driven over RTDE with the ``ur_rtde`` package (``robot=ur_rtde``).

Two RTDE connections: ``RTDEReceiveInterface`` reads the arm's state (pose, speed, joints, protective stop),
``RTDEControlInterface`` uploads ur_rtde's control script and sends ``speedL`` / ``moveL`` / ``speedStop``.
Both run at the controller's RTDE rate (``rtde_frequency``, 500 Hz on an e-Series); the loop's own rate
(``frequency``) is kept with ``initPeriod`` / ``waitPeriod`` against a chain of period starts, so the time
the caller spends between two commands (policy, motion capture) is part of the period, not added to it.

``ur_rtde`` is imported inside :meth:`URRTDEBackend.connect` only: simulated runs never load it. Before
that, :func:`probe_rtde` checks with a short socket timeout that the host answers RTDE on port 30004: an
unreachable or wrong address fails in ``connect_timeout`` seconds with a message that says what to check,
instead of hanging in ur_rtde's own connection attempts.

Commands here are not filtered: wrap the backend in :class:`~dpiil_rl.robots.safety_robot.SafeRobot`.
"""

from __future__ import annotations

import logging
import math
import socket
import struct
import time
from collections.abc import Sequence
from datetime import timedelta
from typing import Any

import numpy as np

from dpiil_rl.robots.interface import RobotBackend, RobotState, RobotUnavailable

log = logging.getLogger(__name__)

RTDE_PORT = 30004  # the controller's RTDE server
_RTDE_REQUEST_PROTOCOL_VERSION = 86  # package type 'V'
_RTDE_TEXT_MESSAGE = 77  # package type 'M' (the controller may send one first)
_RTDE_PROTOCOL_VERSION = 2


def unreachable_message(host: str, what: str) -> str:
    """The error text for a robot that cannot be reached: what failed, then what to check."""
    return (
        f"UR5e at {host} cannot be reached: {what}. Check that the robot is powered on and its arm is "
        "initialised (brakes released), that remote control is enabled (teach pendant: Settings > System > "
        "Remote Control, then switch the pendant to Remote mode), that this computer is on the robot's "
        f"network (ping {host}), and that the address is right: override it with robot.host=<robot ip>."
    )


def _receive_exactly(sock: socket.socket, size: int, deadline: float) -> bytes:
    data = b""
    while len(data) < size:
        remaining = deadline - time.monotonic()
        if remaining <= 0.0:
            raise TimeoutError
        sock.settimeout(remaining)
        chunk = sock.recv(size - len(data))
        if not chunk:
            raise ConnectionError("connection closed")
        data += chunk
    return data


def probe_rtde(host: str, port: int = RTDE_PORT, timeout: float = 2.0) -> None:
    """Raise :class:`RobotUnavailable` unless ``host:port`` answers an RTDE protocol request in ``timeout`` s.

    Opens a TCP connection, sends the RTDE "request protocol version" package and waits for its reply (a
    package of the same type), then closes. Any other outcome (refused, no route, silence, another protocol)
    fails within ``timeout`` seconds. A host name is resolved by the system first, which ``timeout`` does not
    bound: give the robot's IP address.
    """
    deadline = time.monotonic() + timeout
    try:
        sock = socket.create_connection((host, port), timeout=timeout)
    except socket.gaierror as exc:
        raise RobotUnavailable(unreachable_message(host, f"the host name does not resolve ({exc})")) from exc
    except TimeoutError as exc:
        what = f"no answer on the RTDE port {port} within {timeout:g} s"
        raise RobotUnavailable(unreachable_message(host, what)) from exc
    except OSError as exc:
        reason = exc.strerror or str(exc)
        raise RobotUnavailable(unreachable_message(host, f"cannot open the RTDE port {port} ({reason})")) from exc
    with sock:
        try:
            sock.sendall(struct.pack(">HBH", 5, _RTDE_REQUEST_PROTOCOL_VERSION, _RTDE_PROTOCOL_VERSION))
            while True:
                size, kind = struct.unpack(">HB", _receive_exactly(sock, 3, deadline))
                if kind == _RTDE_REQUEST_PROTOCOL_VERSION:
                    return
                if kind != _RTDE_TEXT_MESSAGE or not 3 <= size <= 4096:
                    raise RobotUnavailable(
                        unreachable_message(
                            host, f"port {port} answered, but not with RTDE (is {host} a UR controller?)"
                        )
                    )
                _receive_exactly(sock, size - 3, deadline)
        except TimeoutError as exc:
            raise RobotUnavailable(
                unreachable_message(
                    host, f"port {port} accepts connections but sent no RTDE answer within {timeout:g} s"
                )
            ) from exc
        except (ConnectionError, OSError) as exc:
            raise RobotUnavailable(
                unreachable_message(host, f"port {port} closed the connection without an RTDE answer ({exc})")
            ) from exc


def rotvec_to_quaternion(rotvec: Sequence[float]) -> np.ndarray:
    """UR's axis-angle orientation ``(rx, ry, rz)`` (rad) as a unit quaternion ``(w, x, y, z)``."""
    r = np.asarray(rotvec, dtype=np.float64).reshape(3)
    angle = float(np.linalg.norm(r))
    # sin(angle / 2) / angle, well defined at 0: np.sinc(x) = sin(pi x) / (pi x)
    scale = 0.5 * float(np.sinc(angle / (2.0 * math.pi)))
    return np.concatenate([[math.cos(angle / 2.0)], r * scale])


def _positive(name: str, value: float) -> float:
    number = float(value)
    if not math.isfinite(number) or number <= 0.0:
        raise ValueError(f"URRTDEBackend {name}={value!r}: expected a finite number > 0")
    return number


class URRTDEBackend(RobotBackend):
    """A UR5e at ``host``, commanded by TCP velocity at ``frequency`` Hz (``ur_rtde``).

    ``tcp_offset`` (x, y, z, rx, ry, rz; m, rad) is set on the controller at connect when given (else the
    pendant's active TCP is kept). ``connect_timeout`` (s) bounds the reachability probe. ``rtde_frequency``
    (Hz) is the RTDE rate of both interfaces (500 on e-Series, 125 on CB3); ``move_acceleration`` (m/s^2) is
    the acceleration of ``move_to``.
    """

    def __init__(
        self,
        host: str,
        frequency: float = 20.0,
        tcp_offset: Sequence[float] | None = None,
        connect_timeout: float = 2.0,
        rtde_frequency: float = 500.0,
        move_acceleration: float = 0.5,
    ) -> None:
        super().__init__()
        if not isinstance(host, str) or not host.strip():
            raise ValueError(f"URRTDEBackend host={host!r}: expected the robot's IP address or host name")
        self.host = host.strip()
        self.frequency = _positive("frequency", frequency)
        self.rtde_frequency = _positive("rtde_frequency", rtde_frequency)
        if self.frequency > self.rtde_frequency:
            raise ValueError(
                f"URRTDEBackend frequency={frequency!r} Hz: expected at most the RTDE rate "
                f"rtde_frequency={rtde_frequency!r} Hz"
            )
        self.control_period = 1.0 / self.frequency
        self.connect_timeout = _positive("connect_timeout", connect_timeout)
        self.move_acceleration = _positive("move_acceleration", move_acceleration)
        self.tcp_offset: list[float] | None = None
        if tcp_offset is not None:
            offset = [float(x) for x in tcp_offset]
            if len(offset) != 6 or not all(math.isfinite(x) for x in offset):
                raise ValueError(
                    f"URRTDEBackend tcp_offset={list(tcp_offset)!r}: expected 6 finite numbers "
                    "(x, y, z m; rx, ry, rz rad)"
                )
            self.tcp_offset = offset
        self._step = 1.0 / self.rtde_frequency  # the controller's step: speedL's time, waitPeriod's unit
        self._control: Any = None
        self._receive: Any = None
        self._period_start: timedelta | None = None
        self._saw_protective_stop = False

    # ---------------------------------------------------------------------------- lifecycle
    def connect(self) -> None:
        if self._connected:
            return
        probe_rtde(self.host, RTDE_PORT, self.connect_timeout)
        try:
            import rtde_control
            import rtde_receive
        except ImportError as exc:
            raise ImportError(
                "URRTDEBackend needs the ur_rtde package: pip install ur-rtde==1.6.5 (a dependency of dpiil_rl)"
            ) from exc
        try:
            receive = rtde_receive.RTDEReceiveInterface(self.host, self.rtde_frequency)
        except Exception as exc:  # ur_rtde raises RuntimeError (C++ exceptions), whatever failed
            raise RobotUnavailable(unreachable_message(self.host, f"the RTDE receive interface failed: {exc}")) from exc
        try:
            control = rtde_control.RTDEControlInterface(self.host, self.rtde_frequency)
        except Exception as exc:
            receive.disconnect()
            raise RobotUnavailable(
                unreachable_message(
                    self.host,
                    "the RTDE control interface failed "
                    f"(it uploads a control script, which needs remote control): {exc}",
                )
            ) from exc
        self._receive, self._control = receive, control
        self._period_start = None
        self._saw_protective_stop = False
        super().connect()
        if self.tcp_offset is not None and not control.setTcp(self.tcp_offset):
            self.disconnect()
            raise RobotUnavailable(unreachable_message(self.host, f"setTcp({self.tcp_offset}) was refused"))

    def disconnect(self) -> None:
        """Stop the arm, end the control script and close both connections; errors are logged, not raised."""
        control, receive = self._control, self._receive
        self._control = self._receive = None
        if control is not None:
            for name, call in (
                ("speedStop", lambda: control.speedStop(self.move_acceleration)),
                ("stopScript", control.stopScript),
                ("disconnect", control.disconnect),
            ):
                try:
                    call()
                except Exception as exc:  # the connection may already be gone; keep releasing the rest
                    log.warning("UR5e at %s: %s failed while disconnecting: %s", self.host, name, exc)
        if receive is not None:
            try:
                receive.disconnect()
            except Exception as exc:
                log.warning("UR5e at %s: receive disconnect failed: %s", self.host, exc)
        super().disconnect()

    def _interfaces(self) -> tuple[Any, Any]:
        if self._control is None or self._receive is None:
            raise RuntimeError(
                f"URRTDEBackend({self.host}) is not connected: call connect() (or use it in a with block)"
            )
        return self._control, self._receive

    # ---------------------------------------------------------------------------- state and motion
    def read_state(self) -> RobotState:
        _, receive = self._interfaces()
        if not receive.isConnected():
            raise RobotUnavailable(unreachable_message(self.host, "the RTDE connection was lost"))
        pose = list(receive.getActualTCPPose())
        speed = list(receive.getActualTCPSpeed())
        joints = list(receive.getActualQ())
        if len(pose) != 6 or len(speed) != 6 or len(joints) != 6:
            raise RobotUnavailable(unreachable_message(self.host, "the RTDE state is incomplete"))
        stopped = bool(receive.isProtectiveStopped())
        self._saw_protective_stop |= stopped
        return RobotState(
            tcp_position=np.asarray(pose[:3], dtype=np.float64),
            tcp_quaternion=rotvec_to_quaternion(pose[3:]),
            tcp_velocity=np.asarray(speed[:3], dtype=np.float64),
            joint_positions=np.asarray(joints, dtype=np.float64),
            protective_stop=stopped,
            collision=False,  # the controller reports contacts as protective stops
            time=float(receive.getTimestamp()),
        )

    def command_tcp_velocity(self, velocity: np.ndarray, acceleration: float) -> None:
        """``speedL`` for one control period; returns at the end of the period."""
        control, receive = self._interfaces()
        v = np.asarray(velocity, dtype=np.float64).reshape(3)
        if not np.all(np.isfinite(v)):
            raise ValueError(f"URRTDEBackend.command_tcp_velocity: velocity {v.tolist()}: expected finite m/s")
        rate = _positive("acceleration", acceleration)
        if not self._script_ready(control, receive):
            return
        now: timedelta = control.initPeriod()  # the controller's steady clock
        period = timedelta(seconds=self.control_period)
        if self._period_start is None or now - self._period_start > period:
            self._period_start = now  # first command, or the caller paused: start a new chain of periods
        accepted = control.speedL([float(v[0]), float(v[1]), float(v[2]), 0.0, 0.0, 0.0], rate, self._step)
        # waitPeriod(t) returns at t + one RTDE step: this returns at the end of our control period
        control.waitPeriod(self._period_start + timedelta(seconds=self.control_period - self._step))
        self._period_start += period
        if not accepted:
            log.warning(
                "UR5e at %s: speedL was not accepted (protective stop, or the control script stopped)", self.host
            )

    def stop(self, deceleration: float) -> None:
        control, _ = self._interfaces()
        control.speedStop(_positive("deceleration", deceleration))
        self._period_start = None

    def move_to(self, tcp_position: np.ndarray, speed: float) -> None:
        """``moveL`` to ``tcp_position`` with the current orientation, at ``speed``; blocks until there."""
        control, receive = self._interfaces()
        target = np.asarray(tcp_position, dtype=np.float64).reshape(3)
        if not np.all(np.isfinite(target)):
            raise ValueError(f"URRTDEBackend.move_to: target {target.tolist()}: expected finite metres")
        rate = _positive("speed", speed)
        if not self._script_ready(control, receive):
            raise RuntimeError(f"UR5e at {self.host}: move_to refused: the arm is in a protective stop")
        orientation = list(receive.getActualTCPPose())[3:6]
        pose = [float(x) for x in target] + [float(x) for x in orientation]
        done = control.moveL(pose, rate, self.move_acceleration)
        self._period_start = None
        if not done:
            raise RuntimeError(
                f"UR5e at {self.host}: moveL to {pose} did not complete (protective stop, or the pose is out of reach)"
            )

    def _script_ready(self, control: Any, receive: Any) -> bool:
        """False while the arm is in a protective stop; re-uploads ur_rtde's control script after one.

        A protective stop ends the control script. Once the person has unlocked the arm on the pendant, the
        script is uploaded again (only then: a program stopped on the pendant for any other reason is not
        restarted behind the person's back, that raises instead).
        """
        if receive.isProtectiveStopped():
            self._saw_protective_stop = True
            return False
        if control.isProgramRunning():
            return True
        if self._saw_protective_stop:
            log.warning("UR5e at %s: protective stop unlocked, uploading the control script again", self.host)
            self._saw_protective_stop = False
            if control.reuploadScript():
                self._period_start = None
                return True
        raise RobotUnavailable(
            unreachable_message(
                self.host,
                "the ur_rtde control script is not running (the program was stopped on the pendant); "
                "connect again to restart it",
            )
        )
