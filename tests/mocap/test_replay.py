"""Replay: frames come at the recorded rate on the injected clock; looping; the real-time default."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from dpiil_rl.mocap.base import MocapUnavailable
from dpiil_rl.mocap.replay import ReplayMocap
from dpiil_rl.mocap.trajectory import HandTrajectory, save_trajectory


class ManualClock:
    def __init__(self, now: float = 100.0) -> None:
        self.now = now

    def __call__(self) -> float:
        return self.now


@pytest.fixture
def four_frames(tmp_path: Path) -> Path:
    """Four frames at 10 Hz starting at t = 5 s, x = 0, 1, 2, 3."""
    t = 5.0 + np.array([0.0, 0.1, 0.2, 0.3])
    position = np.column_stack([np.arange(4.0), np.zeros(4), np.zeros(4)])
    quaternion = np.tile([1.0, 0.0, 0.0, 0.0], (4, 1))
    return save_trajectory(tmp_path / "hand.csv", HandTrajectory(t, position, quaternion))


def test_plays_at_the_recorded_rate_on_the_injected_clock(four_frames: Path) -> None:
    clock = ManualClock(100.0)
    replay = ReplayMocap(four_frames, clock=clock)
    with pytest.raises(MocapUnavailable, match="not connected"):
        replay.latest()
    with replay:
        for elapsed, frame in [(0.0, 0), (0.05, 0), (0.099, 0), (0.101, 1), (0.25, 2), (0.35, 3), (5.0, 3)]:
            clock.now = 100.0 + elapsed
            pose = replay.latest()
            assert pose is not None and pose.frame_number == frame, elapsed
            assert pose.position[0] == frame and pose.timestamp == pytest.approx(5.0 + 0.1 * frame)
            assert pose.tracking_valid
        assert replay.finished  # past the last frame's duration: a live stream would have stopped
        assert replay.latest(2) is None  # the file holds one body


def test_received_is_not_refreshed_once_playback_ends(four_frames: Path) -> None:
    clock = ManualClock()
    with ReplayMocap(four_frames, clock=clock) as replay:
        clock.now += 1.0
        last = replay.latest()
        clock.now += 1.0
        again = replay.latest()
        assert again is last and again.age(clock.now) == pytest.approx(1.0)  # type: ignore[union-attr]  # aged on the replay's clock


def test_loop_wraps_and_keeps_counting(four_frames: Path) -> None:
    clock = ManualClock(0.0)
    with ReplayMocap(four_frames, loop=True, clock=clock) as replay:
        assert replay.period == pytest.approx(0.4)
        clock.now = 0.45  # second pass, first frame
        pose = replay.latest()
        assert pose is not None and pose.frame_number == 4 and pose.position[0] == 0
        assert pose.timestamp == pytest.approx(5.4)
        clock.now = 0.4 * 7 + 0.25  # eighth pass, third frame
        pose = replay.latest()
        assert pose is not None and pose.frame_number == 7 * 4 + 2 and pose.position[0] == 2
        assert not replay.finished


def test_reconnect_restarts_playback(four_frames: Path) -> None:
    clock = ManualClock(0.0)
    replay = ReplayMocap(four_frames, clock=clock)
    with replay:
        clock.now = 0.25
        assert replay.latest().frame_number == 2  # type: ignore[union-attr]
    with replay:
        assert replay.latest().frame_number == 0  # type: ignore[union-attr]


def test_mocap_to_robot_applies_to_replayed_poses(four_frames: Path) -> None:
    transform = {"rotation": [[0, -1, 0], [1, 0, 0], [0, 0, 1]], "translation": [0.0, 0.0, 1.0]}  # 90 deg about z
    clock = ManualClock(0.0)
    with ReplayMocap(four_frames, clock=clock, mocap_to_robot=transform) as replay:
        clock.now = 0.15
        pose = replay.latest()
        assert pose is not None
        np.testing.assert_allclose(pose.position, [0.0, 1.0, 1.0], atol=1e-12)
        np.testing.assert_allclose(pose.quaternion, [np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)], atol=1e-12)


def test_default_clock_is_real_time(tmp_path: Path) -> None:
    n = 200
    t = np.arange(n) / 100.0  # 100 Hz, 2 s
    path = save_trajectory(tmp_path / "hand.npz", HandTrajectory(t, np.zeros((n, 3)), np.tile([1.0, 0, 0, 0], (n, 1))))
    with ReplayMocap(path) as replay:
        start = time.monotonic()
        time.sleep(0.05)
        frame = replay.latest().frame_number  # type: ignore[union-attr]
        elapsed = time.monotonic() - start
    assert 4 <= frame <= int(elapsed * 100) + 1


def test_a_frame_is_current_from_its_own_time_on(tmp_path: Path) -> None:
    t = np.array([0.0, 0.25, 0.5])  # exactly representable: no rounding at the boundaries
    path = save_trajectory(tmp_path / "hand.npz", HandTrajectory(t, np.zeros((3, 3)), np.tile([1.0, 0, 0, 0], (3, 1))))
    clock = ManualClock(0.0)
    with ReplayMocap(path, clock=clock) as replay:
        for now, frame in [(0.0, 0), (0.25, 1), (0.5, 2)]:
            clock.now = now
            assert replay.latest().frame_number == frame, now  # type: ignore[union-attr]
