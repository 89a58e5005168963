"""Figures of the safety–effort frontier (:mod:`dpiil_rl.study.frontier`), as PNG.

- :func:`frontier_figure`: interactive success, collisions per run and final autonomous success against
  the person's effort (one measure per figure), one curve per method through its knob values, with the
  bootstrap 95% band over seeds;
- :func:`frontier_overview`: one figure for a study over several geometries: a row per geometry,
  interactive success and collisions per run against the expert share;
- :func:`knob_sensitivity`: the unit-free version of the paper's Fig. 3(d): success against the share of
  the training data each gate counts as risky (1 − quantile), the same unit for every method.
"""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.axes import Axes  # noqa: E402

from dpiil_rl.plots.figure_io import save_figure  # noqa: E402
from dpiil_rl.study.frontier import FrontierPoint  # noqa: E402
from dpiil_rl.study.study_figures import method_color  # noqa: E402
from dpiil_rl.study.study_runs import method_order  # noqa: E402

PANELS = (
    ("interactive_success", "interactive success (%)", 100.0),
    ("collisions", "interactive episodes with a collision, per run", 1.0),
    ("autonomous_success", "autonomous success, final (%)", 100.0),
)
EFFORT_LABELS = {
    "expert_share": "expert share of interactive steps (%)",
    "query_share": "expert queries, share of interactive steps (%)",
    "expert_actions": "expert actions (labels in D)",
}


def frontier_figure(points: Sequence[FrontierPoint], effort: str, path: str | Path, title: str = "") -> Path:
    """Three panels against ``effort`` (one of :data:`EFFORT_LABELS`), a curve and a band per method."""
    fig, axes = plt.subplots(1, len(PANELS), figsize=(5.2 * len(PANELS), 4.4))
    for ax, (key, label, scale) in zip(axes, PANELS):
        _curves(ax, points, effort, key, scale)
        ax.set_ylabel(label)
    for ax in axes:
        ax.set_xlabel(EFFORT_LABELS[effort])
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7, loc="lower right")
    fig.suptitle(
        f"{title}: outcome against the person's effort (each point a knob value; band: bootstrap 95% over seeds)"
    )
    fig.tight_layout()
    return save_figure(fig, path)


def _curves(ax: Axes, points: Sequence[FrontierPoint], effort: str, key: str, scale: float) -> None:
    x_scale = 1.0 if effort == "expert_actions" else 100.0
    for method in method_order({p.method for p in points}):
        pts = sorted((p for p in points if p.method == method), key=lambda p: p.effort[effort])
        x = np.array([p.effort[effort] for p in pts]) * x_scale
        mean, lo, hi = (np.array([p.outcome[key][i] for p in pts]) * scale for i in range(3))
        color = method_color(method)
        ax.plot(x, mean, "o-", color=color, label=method, markersize=4)
        ax.fill_between(x, lo, hi, color=color, alpha=0.15, linewidth=0)


def frontier_overview(
    points: Sequence[FrontierPoint], envs: Sequence[str], path: str | Path, effort: str = "expert_share"
) -> Path:
    """A row per geometry in ``envs``: interactive success and collisions per run against ``effort``, each column
    on one y scale so the geometries compare at a glance."""
    panels = PANELS[:2]
    fig, axes = plt.subplots(len(envs), len(panels), figsize=(10.5, 3.2 * len(envs)), squeeze=False, sharey="col")
    for row, env in zip(axes, envs):
        env_points = [p for p in points if p.env == env]
        for ax, (key, label, scale) in zip(row, panels):
            _curves(ax, env_points, effort, key, scale)
            ax.set_title(env, fontsize=9)
            ax.set_ylabel(label, fontsize=8)
            ax.grid(alpha=0.3)
        row[0].legend(fontsize=7, loc="lower right")
    for ax in axes[-1]:
        ax.set_xlabel(EFFORT_LABELS[effort])
    fig.suptitle("safety against the person's effort on each geometry (band: bootstrap 95% over seeds)", fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path)


def knob_sensitivity(
    points: Sequence[FrontierPoint], methods: Sequence[str], path: str | Path, title: str = ""
) -> Path:
    """Interactive and autonomous success against the share of training data flagged (1 − the knob's quantile)."""
    fig, axes = plt.subplots(1, 2, figsize=(10.5, 4.2))
    for method in method_order(m for m in methods if any(p.method == m for p in points)):
        pts = sorted((p for p in points if p.method == method), key=lambda p: p.knob)
        x = 100.0 * (1.0 - np.array([p.knob for p in pts]))
        for ax, key in zip(axes, ("interactive_success", "autonomous_success")):
            mean = 100.0 * np.array([p.outcome[key][0] for p in pts])
            lo, hi = (
                100.0 * np.array([p.outcome[key][1] for p in pts]),
                100.0 * np.array([p.outcome[key][2] for p in pts]),
            )
            ax.plot(x, mean, "o-", color=method_color(method), label=method)
            ax.fill_between(x, lo, hi, color=method_color(method), alpha=0.15, linewidth=0)
    for ax, key in zip(axes, ("interactive success (%)", "autonomous success, final (%)")):
        ax.set_xlabel("share of the training data counted as risky (%) = 1 − threshold quantile")
        ax.set_ylabel(key)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(f"{title}: threshold sensitivity in the same unit for every gate (unit-free Fig. 3(d))")
    fig.tight_layout()
    return save_figure(fig, path)
