"""The interface every motion-capture source implements: the newest pose of a tracked rigid body.

The teleoperation expert reads the hand's pose through this interface and never knows whether it comes
from Motive (OptiTrack over NatNet) or a recorded file. Reading never blocks: :meth:`MocapSource.latest`
returns the newest pose that has arrived, stamped with :func:`time.monotonic` at arrival, so the
expert's watchdog can stop the robot when the stream goes quiet (a lost connection, the person leaving
the volume) instead of following an old pose.
"""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from dpiil_rl.utils.connectable import Connectable
from dpiil_rl.utils.errors import MocapUnavailable  # noqa: F401  (raised here, defined at the bottom layer)


@dataclass(frozen=True, eq=False)
class MocapPose:
    """One rigid body's pose in one frame. Arrays are read-only copies (the pose is shared across threads)."""

    position: np.ndarray  # (3,) m, in the source's output frame (the robot base frame once mocap_to_robot is set)
    quaternion: np.ndarray  # (4,) unit, w, x, y, z
    timestamp: float  # s, the source's clock (Motive: since it started; replay: the file's t)
    received: float  # s, time.monotonic() when the pose arrived here: what a watchdog compares against
    tracking_valid: bool  # False: the tracker lost the body this frame; its pose is the last solved one
    frame_number: int  # the source's frame counter (increases by one per captured frame)

    def __post_init__(self) -> None:
        for name, shape in (("position", (3,)), ("quaternion", (4,))):
            value = np.array(getattr(self, name), dtype=np.float64)
            if value.shape != shape:
                raise ValueError(f"MocapPose.{name} has shape {value.shape}, expected {shape}")
            value.setflags(write=False)
            object.__setattr__(self, name, value)

    def age(self, now: float | None = None) -> float:
        """Seconds since the pose arrived (``now`` on :func:`time.monotonic`, default: the current time)."""
        return (time.monotonic() if now is None else now) - self.received


class MocapSource(Connectable, ABC):
    """A stream of rigid-body poses. Open with :meth:`connect` (or ``with source:``); read with :meth:`latest`."""

    #: human-readable description used in log and error messages
    name: str = "motion capture"

    def __init__(self, rigid_body_id: int = 1) -> None:
        self.rigid_body_id = int(rigid_body_id)
        self._connected = False

    # ---------------------------------------------------------------------------- reading
    @abstractmethod
    def latest(self, rigid_body_id: int | None = None) -> MocapPose | None:
        """The newest pose of ``rigid_body_id`` (default: the configured body), None if none has arrived yet.

        Never blocks. The pose may be old: check :meth:`MocapPose.age` (or use :meth:`fresh`).
        Raises :class:`MocapUnavailable` when the source is not connected.
        """

    def fresh(self, max_age_s: float, rigid_body_id: int | None = None, now: float | None = None) -> MocapPose | None:
        """:meth:`latest` if a robot may follow it: None when it arrived more than ``max_age_s`` seconds before
        ``now`` (default: :func:`time.monotonic`; a replay on another clock passes that clock's time) or the
        tracker lost the body in that frame."""
        pose = self.latest(rigid_body_id)
        if pose is None or not pose.tracking_valid or pose.age(now) > max_age_s:
            return None
        return pose

    def _require_connected(self) -> None:
        if not self._connected:
            raise MocapUnavailable(f"{self.name} is not connected: call connect() first (or use it in a with-block)")
