"""The ring-safety figure: how often each gate handed over as a function of the robot's own speed, per stage.

One panel per stage (and one for every step), one line per (study, method): over the robot-driven
interactive steps pooled over seeds, the share at which the gate handed over, per bin of the end-effector
speed coming into the state (:func:`~dpiil_rl.study.ring_safety.handover_curve`). A gate whose risk falls
with the robot's speed (DPIIL's precision term) draws a falling line; a gate blind to speed a flat one.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from dpiil_rl.plots.figure_io import save_figure  # noqa: E402
from dpiil_rl.study.ring_safety import ALL, SPEED_BINS, MethodSafety, handover_curve  # noqa: E402

#: a bin is drawn only with at least this many robot-driven steps (pooled over seeds)
MIN_STEPS = 50


def _bin_label(lo: float, hi: float) -> str:
    return f"≥ {lo:g}" if math.isinf(hi) else f"{lo:g}–{hi:g}"


def handover_figure(groups: Sequence[MethodSafety], path: str | Path, min_steps: int = MIN_STEPS) -> Path:
    """Draw the hand-over share against the robot's speed for ``groups``; returns ``path``."""
    groups = [g for g in groups if g.interactive]
    if not groups:
        raise ValueError("handover_figure: no method with interactive episodes to draw")
    keys = [ALL] + sorted({k for g in groups for r in g.staged_runs() for k in r.steps if k != ALL})
    cols = min(3, len(keys) + 1)  # the panels, then one slot for the legend
    rows = -(-(len(keys) + 1) // cols)
    fig, grid = plt.subplots(rows, cols, figsize=(4.2 * cols, 3.4 * rows), squeeze=False, sharey=True)
    axes = grid.reshape(-1)
    labels = [_bin_label(lo, hi) for lo, hi in zip(SPEED_BINS[:-1], SPEED_BINS[1:])]
    studies = list(dict.fromkeys(g.study for g in groups))
    methods = list(dict.fromkeys(g.method for g in groups))
    colors = {m: plt.get_cmap("tab10")(i) for i, m in enumerate(methods)}
    styles = ["-", "--", ":", "-."]
    for ax, key in zip(axes, keys):
        for g in groups:
            if not g.runs_for(key):
                continue
            curve = handover_curve(g, key)
            xs = [i for i, (_, share, n) in enumerate(curve) if n >= min_steps and not math.isnan(share)]
            if not xs:
                continue
            ys = [100.0 * curve[i][1] for i in xs]
            ax.plot(
                xs,
                ys,
                styles[studies.index(g.study) % len(styles)],
                marker="o",
                ms=3,
                color=colors[g.method],
                label=f"{g.method}, {g.study} ({len(g.runs_for(key))} seed{'s' if len(g.runs_for(key)) > 1 else ''})",
            )
        ax.set_title("all steps" if key == ALL else groups[0].stages[key], fontsize=10)
        ax.set_xticks(range(len(labels)), labels, rotation=45, fontsize=7)
        ax.set_xlabel("robot speed into the state (cm/step)", fontsize=8)
        ax.grid(alpha=0.3)
    for row in grid:
        row[0].set_ylabel("gate handed over (% of robot-driven steps)", fontsize=8)
    handles, names = axes[0].get_legend_handles_labels()
    for ax in axes[len(keys) :]:
        ax.axis("off")
    axes[len(keys)].legend(handles, names, loc="center", fontsize=8)
    fig.suptitle("ring, interactive steps: hand-over rate against the robot's own speed", fontsize=10)
    return save_figure(fig, path)
