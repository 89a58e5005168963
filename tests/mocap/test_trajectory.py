"""Trajectory files: round trips, and every validation error names the file, the row and the value."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dpiil_rl.mocap.base import MocapUnavailable
from dpiil_rl.mocap.replay import ReplayMocap
from dpiil_rl.mocap.trajectory import (
    COLUMNS,
    HandTrajectory,
    TrajectoryFileError,
    load_trajectory,
    record_trajectory,
    save_trajectory,
)

HEADER = ",".join(COLUMNS)


def write(tmp_path: Path, text: str, name: str = "hand.csv") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def circle(n: int = 20, rate: float = 100.0) -> HandTrajectory:
    t = 3.0 + np.arange(n) / rate
    angle = np.linspace(0, np.pi, n)
    position = np.column_stack([0.4 + 0.1 * np.cos(angle), 0.1 * np.sin(angle), np.full(n, 0.3)])
    quaternion = np.column_stack([np.cos(angle / 2), np.zeros(n), np.zeros(n), np.sin(angle / 2)])
    return HandTrajectory(t, position, quaternion)


@pytest.mark.parametrize("suffix", [".csv", ".npz"])
def test_round_trip(tmp_path: Path, suffix: str) -> None:
    original = circle()
    loaded = load_trajectory(save_trajectory(tmp_path / f"hand{suffix}", original))
    np.testing.assert_array_equal(loaded.t, original.t)
    np.testing.assert_allclose(loaded.position, original.position, rtol=0, atol=1e-12)
    np.testing.assert_allclose(loaded.quaternion, original.quaternion, rtol=0, atol=1e-12)


def test_csv_column_order_and_extra_columns_do_not_matter(tmp_path: Path) -> None:
    path = write(tmp_path, "qw,qx,qy,qz,note,t,x,y,z\n1,0,0,0,start,0.0,1,2,3\n0,1,0,0,,0.01,4,5,6\n")
    trajectory = load_trajectory(path)
    np.testing.assert_array_equal(trajectory.position, [[1, 2, 3], [4, 5, 6]])
    np.testing.assert_array_equal(trajectory.quaternion, [[1, 0, 0, 0], [0, 1, 0, 0]])


def test_nearly_unit_quaternions_are_normalised(tmp_path: Path) -> None:
    trajectory = load_trajectory(write(tmp_path, f"{HEADER}\n0,0,0,0,1.004,0,0,0\n"))
    np.testing.assert_allclose(trajectory.quaternion, [[1, 0, 0, 0]])


@pytest.mark.parametrize(
    "text, message",
    [
        ("", "is empty"),
        ("t,x,y,z,qw\n0,0,0,0,1\n", r"missing column\(s\) qx, qy, qz"),
        (f"{HEADER}\n", "has no rows"),
        (
            f"{HEADER}\n0,0,0,0,1,0,0,0\n0.01,0,0,0,1,0,0,0\n0.005,0,0,0,1,0,0,0\n",
            r"time must strictly increase, but row 2 \(line 4\) has t = 0.005 after t = 0.01 in row 1 \(line 3\)",
        ),
        (f"{HEADER}\n0,0,0,0,1,0,0,0\n0,0,0,0,1,0,0,0\n", r"row 1 \(line 3\) has t = 0 after t = 0"),
        (f"{HEADER}\n0,0,0,0,1,0,0,0\n0.01,abc,0,0,1,0,0,0\n", r"row 1 \(line 3\), column x = 'abc' is not a number"),
        (f"{HEADER}\n0,0,0,0,1,0,0,0\n0.01,0,0\n", r"row 1 \(line 3\), column z = '' is not a number"),
        (f"{HEADER}\n0,0,nan,0,1,0,0,0\n", r"row 0 \(line 2\) has a non-finite value"),
        (f"{HEADER}\n0,0,0,0,1,0,0,0\n0.01,0,0,0,0.5,0,0,0\n", r"row 1 \(line 3\) has a quaternion .* norm 0.5"),
    ],
)
def test_csv_errors(tmp_path: Path, text: str, message: str) -> None:
    path = write(tmp_path, text)
    with pytest.raises(TrajectoryFileError, match=message) as info:
        load_trajectory(path)
    assert str(path) in str(info.value)


def test_npz_errors(tmp_path: Path) -> None:
    columns = {name: np.zeros(3) for name in COLUMNS}
    columns["qw"] = np.ones(3)
    columns["t"] = np.array([0.0, 0.02, 0.01])
    np.savez(tmp_path / "a.npz", **columns)
    with pytest.raises(TrajectoryFileError, match=r"a.npz: time must strictly increase, but row 2 has t = 0.01"):
        load_trajectory(tmp_path / "a.npz")
    np.savez(tmp_path / "b.npz", **{k: v for k, v in columns.items() if k != "qx"})
    with pytest.raises(TrajectoryFileError, match=r"b.npz: missing column\(s\) qx"):
        load_trajectory(tmp_path / "b.npz")
    np.savez(tmp_path / "c.npz", **{**columns, "t": np.array([0.0, 0.1])})
    with pytest.raises(TrajectoryFileError, match="different lengths"):
        load_trajectory(tmp_path / "c.npz")
    np.savez(tmp_path / "d.npz", **{**columns, "x": np.zeros((3, 2))})
    with pytest.raises(TrajectoryFileError, match=r"array 'x' has shape \(3, 2\)"):
        load_trajectory(tmp_path / "d.npz")


def test_missing_file_and_unknown_suffix(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="nowhere.csv does not exist"):
        load_trajectory(tmp_path / "nowhere.csv")
    with pytest.raises(TrajectoryFileError, match="expected .csv or .npz"):
        load_trajectory(write(tmp_path, "x", "hand.txt"))


class ManualClock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.now += seconds


def test_record_then_replay_gives_back_the_recording(tmp_path: Path) -> None:
    original = circle(n=30)
    clock = ManualClock()
    source = ReplayMocap(save_trajectory(tmp_path / "original.npz", original), clock=clock)
    with source:
        recorded = record_trajectory(
            source, tmp_path / "recorded.csv", duration_s=0.5, poll_s=0.001, clock=clock, sleep=clock.sleep
        )
    assert len(recorded) == len(original)
    np.testing.assert_allclose(recorded.t, original.t - original.t[0], atol=1e-9)
    again = load_trajectory(tmp_path / "recorded.csv")
    np.testing.assert_allclose(again.position, original.position, atol=1e-12)
    np.testing.assert_allclose(again.quaternion, original.quaternion, atol=1e-12)


def test_record_without_poses_is_an_error(tmp_path: Path) -> None:
    clock = ManualClock()
    source = ReplayMocap(save_trajectory(tmp_path / "o.csv", circle()), rigid_body_id=1, clock=clock)
    with source, pytest.raises(MocapUnavailable, match="no tracked pose of rigid body 4 in 0.05 s"):
        record_trajectory(source, tmp_path / "r.csv", duration_s=0.05, rigid_body_id=4, clock=clock, sleep=clock.sleep)
    assert not (tmp_path / "r.csv").exists()
