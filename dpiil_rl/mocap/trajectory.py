"""Recorded hand trajectories: the file format :class:`~dpiil_rl.mocap.replay.ReplayMocap` plays back.

One rigid body, one row per captured frame, columns ``t, x, y, z, qw, qx, qy, qz`` (s, m, unit
quaternion w first), as a CSV file with that header (any column order, extra columns ignored) or a
``.npz`` with one 1-D array per column. Time must strictly increase; its origin does not matter.
Loading checks everything and names the file, the row and the value that is wrong: a bad file should
fail when it is opened, not move a robot strangely halfway through a run.

:func:`record_trajectory` writes such a file from any :class:`MocapSource` (e.g. Motive), so a
person's motion can be captured once and replayed in simulation or tests.
"""

from __future__ import annotations

import csv
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dpiil_rl.mocap.base import MocapSource, MocapUnavailable

log = logging.getLogger(__name__)

COLUMNS = ("t", "x", "y", "z", "qw", "qx", "qy", "qz")
_QUATERNION_TOLERANCE = 1e-2  # |‖q‖ - 1| above this is a wrong column, not rounding


class TrajectoryFileError(ValueError):
    """A trajectory file cannot be used; the message names the file, the row and what was expected."""


@dataclass(frozen=True, eq=False)
class HandTrajectory:
    t: np.ndarray  # (N,) s, strictly increasing
    position: np.ndarray  # (N, 3) m
    quaternion: np.ndarray  # (N, 4) unit, w, x, y, z

    def __len__(self) -> int:
        return int(self.t.shape[0])


def load_trajectory(path: str | Path) -> HandTrajectory:
    """Read and validate a ``.csv`` or ``.npz`` trajectory (see the module docstring for the format)."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"hand trajectory {path} does not exist (record one with record_trajectory)")
    if path.suffix == ".csv":
        data, line_of = _read_csv(path)
    elif path.suffix == ".npz":
        data, line_of = _read_npz(path), None
    else:
        raise TrajectoryFileError(f"{path}: unknown file type {path.suffix!r}; expected .csv or .npz")
    return _validate(path, data, line_of)


def save_trajectory(path: str | Path, trajectory: HandTrajectory) -> Path:
    """Write ``trajectory`` as ``.csv`` or ``.npz`` (by the suffix of ``path``); returns the path."""
    path = Path(path)
    table = np.column_stack([trajectory.t, trajectory.position, trajectory.quaternion])
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix == ".csv":
        with path.open("w", newline="") as handle:
            writer = csv.writer(handle)
            writer.writerow(COLUMNS)
            writer.writerows([[repr(float(v)) for v in row] for row in table])
    elif path.suffix == ".npz":
        np.savez(path, **{name: table[:, i] for i, name in enumerate(COLUMNS)})
    else:
        raise TrajectoryFileError(f"{path}: unknown file type {path.suffix!r}; expected .csv or .npz")
    return path


def record_trajectory(
    source: MocapSource,
    path: str | Path,
    duration_s: float,
    rigid_body_id: int | None = None,
    poll_s: float = 0.002,
    clock: Callable[[], float] = time.monotonic,
    sleep: Callable[[float], None] = time.sleep,
) -> HandTrajectory:
    """Record ``duration_s`` seconds of one rigid body from a connected ``source`` into ``path``.

    Every new frame (by frame number) is kept with the source's own timestamp, so the file replays at
    the rate it was captured. Frames where the tracker lost the body are skipped (a replayed hand is
    always tracked). ``clock`` and ``sleep`` default to real time; a simulation passes its own.
    """
    if duration_s <= 0 or poll_s <= 0:
        raise ValueError(f"record_trajectory: duration_s = {duration_s}, poll_s = {poll_s}; expected positive seconds")
    rows: list[list[float]] = []
    last_frame: int | None = None
    untracked = 0
    end = clock() + duration_s
    while clock() < end:
        pose = source.latest(rigid_body_id)
        if pose is not None and pose.frame_number != last_frame:
            last_frame = pose.frame_number
            if not pose.tracking_valid:
                untracked += 1
            elif not rows or pose.timestamp > rows[-1][0]:
                rows.append([pose.timestamp, *pose.position, *pose.quaternion])
        sleep(poll_s)
    body = source.rigid_body_id if rigid_body_id is None else rigid_body_id
    if not rows:
        raise MocapUnavailable(
            f"{source.name}: no tracked pose of rigid body {body} in {duration_s:g} s; check the "
            "rigid body id (Motive's Assets pane, 'Streaming ID') and that the body is in view"
        )
    if untracked:
        log.warning("record_trajectory: skipped %d frames where rigid body %s was not tracked", untracked, body)
    table = np.asarray(rows)
    trajectory = HandTrajectory(table[:, 0] - table[0, 0], table[:, 1:4], table[:, 4:8])
    save_trajectory(path, trajectory)
    return trajectory


# ---------------------------------------------------------------------------- reading and checking
def _read_csv(path: Path) -> tuple[dict[str, np.ndarray], Callable[[int], str]]:
    with path.open(newline="") as handle:
        rows = list(csv.reader(handle))
    rows = [row for row in rows if any(cell.strip() for cell in row)]
    if not rows:
        raise TrajectoryFileError(f"{path} is empty; expected a header row {','.join(COLUMNS)} and one row per frame")
    header = [cell.strip() for cell in rows[0]]
    _check_columns(path, header)
    index = {name: header.index(name) for name in COLUMNS}
    data = {name: np.empty(len(rows) - 1) for name in COLUMNS}
    for r, row in enumerate(rows[1:]):
        for name, col in index.items():
            cell = row[col].strip() if col < len(row) else ""
            try:
                data[name][r] = float(cell)
            except ValueError:
                raise TrajectoryFileError(
                    f"{path}: row {r} (line {r + 2}), column {name} = {cell!r} is not a number"
                ) from None
    return data, lambda r: f"row {r} (line {r + 2})"


def _read_npz(path: Path) -> dict[str, np.ndarray]:
    try:
        with np.load(path, allow_pickle=False) as archive:
            arrays = {name: np.asarray(archive[name]) for name in archive.files}
    except (OSError, ValueError) as err:
        raise TrajectoryFileError(f"{path} is not a readable .npz archive ({err})") from err
    _check_columns(path, list(arrays))
    data = {}
    for name in COLUMNS:
        value = arrays[name]
        if value.ndim != 1 or not np.issubdtype(value.dtype, np.number):
            raise TrajectoryFileError(
                f"{path}: array {name!r} has shape {value.shape} and dtype {value.dtype}; "
                "expected a 1-D numeric array (one value per frame)"
            )
        data[name] = value.astype(np.float64)
    lengths = {name: len(v) for name, v in data.items()}
    if len(set(lengths.values())) > 1:
        raise TrajectoryFileError(
            f"{path}: columns have different lengths {lengths}; expected one value per frame in each"
        )
    return data


def _check_columns(path: Path, found: list[str]) -> None:
    missing = [name for name in COLUMNS if name not in found]
    if missing:
        raise TrajectoryFileError(
            f"{path}: missing column(s) {', '.join(missing)}; expected {', '.join(COLUMNS)} "
            f"(found {', '.join(found) or 'none'})"
        )


def _validate(path: Path, data: dict[str, np.ndarray], line_of: Callable[[int], str] | None) -> HandTrajectory:
    where = line_of or (lambda r: f"row {r}")
    t = data["t"]
    if len(t) == 0:
        raise TrajectoryFileError(f"{path} has no rows; expected at least one frame")
    table = np.column_stack([data[name] for name in COLUMNS])
    bad = np.flatnonzero(~np.isfinite(table).all(axis=1))
    if bad.size:
        r = int(bad[0])
        raise TrajectoryFileError(f"{path}: {where(r)} has a non-finite value: {dict(zip(COLUMNS, table[r].tolist()))}")
    steps = np.flatnonzero(np.diff(t) <= 0)
    if steps.size:
        r = int(steps[0]) + 1
        raise TrajectoryFileError(
            f"{path}: time must strictly increase, but {where(r)} has t = {t[r]:g} after "
            f"t = {t[r - 1]:g} in {where(r - 1)}"
        )
    quaternion = table[:, 4:8]
    norms = np.linalg.norm(quaternion, axis=1)
    off = np.flatnonzero(np.abs(norms - 1.0) > _QUATERNION_TOLERANCE)
    if off.size:
        r = int(off[0])
        raise TrajectoryFileError(
            f"{path}: {where(r)} has a quaternion (qw, qx, qy, qz) = {quaternion[r].tolist()} of "
            f"norm {norms[r]:.4g}; expected a unit quaternion (are the columns right?)"
        )
    return HandTrajectory(t.copy(), table[:, 1:4].copy(), quaternion / norms[:, None])
