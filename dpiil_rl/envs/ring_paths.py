"""End-effector paths of ring-threading episodes: top view (x, y) and side view (x, z), with the pegs.

Segments driven by the expert are orange, the robot's blue; each episode ends in a green dot
(threaded) or a red cross (timed out). Used by the run's plot hook (``plots/paths_*.png``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import Circle, Rectangle  # noqa: E402

from dpiil_rl.envs.ring_task import RingGeometry  # noqa: E402
from dpiil_rl.plots.figure_io import save_figure  # noqa: E402
from dpiil_rl.plots.mode_path import EXPERT, ROBOT, draw_mode_path  # noqa: E402


def _draw_pegs(top: Any, side: Any, g: RingGeometry) -> None:
    half_square = 0.016
    top.add_patch(Circle(g.round_peg_xy, g.peg_radius, color="0.35", zorder=3))
    top.add_patch(Circle(g.round_peg_xy, g.ring_inner_radius, fill=False, ls=":", ec="0.35", zorder=3))
    sx, sy = g.square_peg_xy
    top.add_patch(
        Rectangle((sx - half_square, sy - half_square), 2 * half_square, 2 * half_square, color="0.6", zorder=3)
    )
    px, _ = g.round_peg_xy
    side.add_patch(
        Rectangle((px - g.peg_radius, g.table_z), 2 * g.peg_radius, g.peg_top_z - g.table_z, color="0.35", zorder=3)
    )
    side.axhline(g.table_z, color="0.5", lw=1)


def plot_ring_paths(
    paths: Sequence[dict[str, Any]], success: dict[int, bool], geometry: RingGeometry, path: str | Path, title: str = ""
) -> Path:
    """Draw ``paths`` (rows of ``paths.jsonl``; positions are end-effector xyz) in a top and a side view."""
    fig, (top, side) = plt.subplots(1, 2, figsize=(10, 4.2))
    _draw_pegs(top, side, geometry)
    for row in paths:
        pos = row["positions"]
        xs, ys, zs = [p[0] for p in pos], [p[1] for p in pos], [p[2] for p in pos]
        ok = success.get(int(row["episode"]))
        draw_mode_path(top, xs, ys, row["expert_mode"], ok)
        draw_mode_path(side, xs, zs, row["expert_mode"], ok)
    top.set_xlabel("x (m)")
    top.set_ylabel("y (m)")
    top.set_aspect("equal")
    top.set_title("top view (end effector)", fontsize=9)
    side.set_xlabel("x (m)")
    side.set_ylabel("z (m)")
    side.set_title("side view", fontsize=9)
    for ax in (top, side):
        ax.autoscale_view()
        ax.grid(alpha=0.3)
    top.plot([], [], color=EXPERT, label="expert in control")
    top.plot([], [], color=ROBOT, label="robot in control")
    top.legend(fontsize=7, loc="upper left")
    fig.suptitle(title)
    return save_figure(fig, path)
