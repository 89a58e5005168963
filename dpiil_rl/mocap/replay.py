"""``mocap=replay``: a recorded hand trajectory played back as if Motive streamed it.

The teleoperation path (mocap source -> expert -> robot) then runs without a capture volume: in
simulation, in tests, or to repeat one person's motion exactly. Playback holds each recorded frame
until the next one is due, so it runs at the recorded rate; ``frame_number`` counts frames played,
``timestamp`` is the file's time (continuing to grow over loops).

The clock is real time (:func:`time.monotonic`) since :meth:`ReplayMocap.connect` by default; pass any
``clock`` callable (e.g. a simulation's time) to play on that instead. ``received`` is the clock's time
when :meth:`latest` first returned a frame, so, as with a live stream, a pose stops being refreshed once
playback ends (``loop=False``) and a watchdog sees it age: on real time by default, on the given clock
otherwise (compare with ``pose.age(now=clock())``; a slow simulation then never looks stale).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from dpiil_rl.mocap.base import MocapPose, MocapSource
from dpiil_rl.mocap.trajectory import load_trajectory
from dpiil_rl.mocap.transform import RigidTransform


class ReplayMocap(MocapSource):
    def __init__(
        self,
        path: str | Path,
        rigid_body_id: int = 1,
        loop: bool = False,
        clock: Callable[[], float] | None = None,
        mocap_to_robot: RigidTransform | Mapping[str, Any] | None = None,
    ) -> None:
        super().__init__(rigid_body_id)
        self.path = Path(path)
        self.trajectory = load_trajectory(self.path)
        self.loop = bool(loop)
        self.clock: Callable[[], float] = time.monotonic if clock is None else clock
        self.name = f"replay of {self.path.name}"
        transform = RigidTransform.from_config(mocap_to_robot)
        self._position, self._quaternion = transform.apply(self.trajectory.position, self.trajectory.quaternion)
        self._t = self.trajectory.t - self.trajectory.t[0]
        n = len(self.trajectory)
        #: s, one pass of the file: the last frame is held as long as the one before it (a one-frame file: forever)
        self.period = float(self._t[-1] + (self._t[-1] - self._t[-2])) if n > 1 else float("inf")
        self._start = 0.0
        self._current: MocapPose | None = None

    def connect(self) -> None:
        """Start (or, after :meth:`disconnect`, restart) playback at the first frame."""
        if self.is_connected:
            return
        self._start = self.clock()
        self._current = None
        super().connect()

    @property
    def elapsed(self) -> float:
        """Seconds of playback (on ``clock``) since :meth:`connect`."""
        return max(0.0, self.clock() - self._start)

    @property
    def finished(self) -> bool:
        """Playback without ``loop`` has played the last frame for its full duration: no new poses will come."""
        return self.is_connected and not self.loop and self.elapsed >= self.period

    def latest(self, rigid_body_id: int | None = None) -> MocapPose | None:
        self._require_connected()
        if rigid_body_id is not None and int(rigid_body_id) != self.rigid_body_id:
            return None
        elapsed = self.elapsed
        n = len(self._t)
        lap, phase = divmod(elapsed, self.period) if self.loop and n > 1 else (0.0, elapsed)
        index = int(np.clip(np.searchsorted(self._t, phase, side="right") - 1, 0, n - 1))
        frame = int(lap) * n + index
        if self._current is None or self._current.frame_number != frame:
            self._current = MocapPose(
                self._position[index],
                self._quaternion[index],
                timestamp=float(self.trajectory.t[index] + lap * self.period),
                received=self.clock(),
                tracking_valid=True,
                frame_number=frame,
            )
        return self._current
