"""Paths of the controlled point in the arm-reaching tasks: top view (x, y) and side view, with the scene.

The side view looks across the approach: its horizontal axis is x or y, whichever separates the start
from the target more (x for the shaft, y for ring_real).

Segments driven by the expert are orange, the robot's blue; each episode ends in a green dot (success)
or a red cross (failure). Used by the run's plot hook through :meth:`ShaftEnv.plot_paths`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import Circle, Rectangle  # noqa: E402

from dpiil_rl.envs.shaft_task import ShaftTask  # noqa: E402
from dpiil_rl.plots.figure_io import save_figure  # noqa: E402
from dpiil_rl.plots.mode_path import EXPERT, ROBOT, draw_mode_path  # noqa: E402


def side_axis(task: ShaftTask) -> int:
    """0 (x) or 1 (y): the horizontal axis along which the start lies farther from the target."""
    gap = np.abs(np.array(task.start_position) + np.array(task.tool_offset) - task.target_position)
    return int(gap[1] > gap[0])


def _draw_scene(top: Any, side: Any, task: ShaftTask, axis: int) -> None:
    for shape in task.scene.objects:
        centre, half = np.array(shape.pos), shape.half_extents
        colour = "tab:olive" if shape.role == "target" else "0.45"
        if shape.shape in ("cylinder", "sphere"):
            top.add_patch(Circle((centre[0], centre[1]), half[0], color=colour, zorder=3))
        else:
            top.add_patch(
                Rectangle((centre[0] - half[0], centre[1] - half[1]), 2 * half[0], 2 * half[1], color=colour, zorder=3)
            )
        side.add_patch(
            Rectangle(
                (centre[axis] - half[axis], centre[2] - half[2]),
                2 * half[axis],
                2 * half[2],
                color=colour,
                alpha=0.8,
                zorder=3,
            )
        )
    side.axhline(task.scene.table_top, color="0.5", lw=1)
    goal = task.goal_position
    top.add_patch(Circle((goal[0], goal[1]), task.goal_radius, fill=False, ec="tab:green", lw=1.2, zorder=4))
    lo, hi = task.goal_depth
    side.add_patch(
        Rectangle(
            (goal[axis] - task.goal_radius, goal[2] + lo),
            2 * task.goal_radius,
            hi - lo,
            fill=False,
            ec="tab:green",
            lw=1.2,
            zorder=4,
        )
    )


def plot_shaft_paths(
    paths: Sequence[dict[str, Any]], success: dict[int, bool], task: ShaftTask, path: str | Path, title: str = ""
) -> Path:
    """Draw ``paths`` (rows of ``paths.jsonl``; positions are TCP xyz, shown as the controlled point)."""
    fig, (top, side) = plt.subplots(1, 2, figsize=(10, 4.2))
    axis = side_axis(task)
    _draw_scene(top, side, task, axis)
    offset = np.array(task.tool_offset)
    for row in paths:
        pos = np.asarray(row["positions"], dtype=np.float64).reshape(-1, 3) + offset
        ok = success.get(int(row["episode"]))
        draw_mode_path(top, pos[:, 0].tolist(), pos[:, 1].tolist(), row["expert_mode"], ok, zorder=5)
        draw_mode_path(side, pos[:, axis].tolist(), pos[:, 2].tolist(), row["expert_mode"], ok, zorder=5)
    top.set_xlabel("x (m)")
    top.set_ylabel("y (m)")
    top.set_title("top view (controlled point)", fontsize=9)
    side.set_xlabel(f"{'xy'[axis]} (m)")
    side.set_ylabel("z (m)")
    side.set_title("side view", fontsize=9)
    for ax in (top, side):
        ax.autoscale_view()
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(alpha=0.3)
    top.plot([], [], color=EXPERT, label="expert in control")
    top.plot([], [], color=ROBOT, label="robot in control")
    top.legend(fontsize=7, loc="upper left")
    fig.suptitle(title)
    return save_figure(fig, path)
