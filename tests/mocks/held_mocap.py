"""Test-only motion capture: the test puts the hand where it wants, as fresh, stale or untracked."""

from __future__ import annotations

import time

import numpy as np

from dpiil_rl.mocap.base import MocapPose, MocapSource


class HeldMocap(MocapSource):
    def __init__(self, rigid_body_id: int = 1) -> None:
        super().__init__(rigid_body_id)
        self.name = "held hand"
        self.pose: MocapPose | None = None
        self._frame = 0

    def put(self, position, age: float = 0.0, tracking_valid: bool = True) -> None:
        self._frame += 1
        self.pose = MocapPose(
            np.asarray(position, dtype=float),
            np.array([1.0, 0, 0, 0]),
            timestamp=float(self._frame),
            received=time.monotonic() - age,
            tracking_valid=tracking_valid,
            frame_number=self._frame,
        )

    def latest(self, rigid_body_id: int | None = None) -> MocapPose | None:
        self._require_connected()
        return self.pose
