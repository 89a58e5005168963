"""Figures of the safety–effort frontier (:mod:`dpiil_rl.study.frontier`), as PNG.

- :func:`frontier_figure`: interactive success, collisions per run and final autonomous success against
  the person's effort (one measure per figure), one curve per method through its knob values, with the
  bootstrap 95% band over seeds;
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
    x_scale = 1.0 if effort == "expert_actions" else 100.0
    for method in method_order({p.method for p in points}):
        pts = sorted((p for p in points if p.method == method), key=lambda p: p.effort[effort])
        x = np.array([p.effort[effort] for p in pts]) * x_scale
        for ax, (key, label, scale) in zip(axes, PANELS):
            mean = np.array([p.outcome[key][0] for p in pts]) * scale
            lo = np.array([p.outcome[key][1] for p in pts]) * scale
            hi = np.array([p.outcome[key][2] for p in pts]) * scale
            color = method_color(method)
            ax.plot(x, mean, "o-", color=color, label=method, markersize=4)
            ax.fill_between(x, lo, hi, color=color, alpha=0.15, linewidth=0)
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
