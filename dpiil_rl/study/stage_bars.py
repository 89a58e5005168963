"""How far episodes got, as a figure: one stacked bar per method, split by the furthest stage reached
(or, with ``success_last=False``, any count per stage, such as where a method's expert pairs were taken).

Every bar is 100% of the method's episodes (pooled over seeds); the segments go from the earliest stage
(stopped there: a failure) to the last (success), so where each method's failures stop reads at a glance.
"""

from __future__ import annotations

from pathlib import Path
from typing import Mapping, Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from dpiil_rl.plots.figure_io import save_figure  # noqa: E402
from dpiil_rl.study.stage_table import StageCounts  # noqa: E402


def stage_colors(n: int, success_last: bool = True) -> list:
    """Reds for the stages an episode can stop at (darker = earlier), green for the last (success); with
    ``success_last=False`` (counts of steps or pairs, where no stage means success) one blue scale in order."""
    if not success_last:
        blues = plt.get_cmap("Blues")
        return [blues(0.3 + 0.6 * i / max(1, n - 1)) for i in range(n)]
    reds = plt.get_cmap("OrRd")
    fails = [reds(0.85 - 0.6 * i / max(1, n - 2)) for i in range(n - 1)]
    return fails + [plt.get_cmap("Greens")(0.6)]


def stage_bars(
    panels: Mapping[str, Sequence[StageCounts]],
    stages: Sequence[str],
    path: str | Path,
    title: str = "",
    xlabel: str = "% of episodes (furthest stage reached)",
    success_last: bool = True,
) -> Path:
    """One panel per entry of ``panels`` (e.g. ``{"autonomous, last iteration": counts, "interactive": counts}``),
    one horizontal bar per method with episodes; returns ``path``. ``counts`` may count anything per stage
    (e.g. expert pairs: then ``xlabel`` says what, and ``success_last=False`` colours the stages in order)."""
    panels = {name: [c for c in counts if c.episodes] for name, counts in panels.items()}
    panels = {name: counts for name, counts in panels.items() if counts}
    if not panels or len(stages) < 2:
        raise ValueError(
            f"stage_bars: no episodes with stages {list(stages)} to draw (expected staged episode records)"
        )
    colors = stage_colors(len(stages), success_last)
    rows = max(len(c) for c in panels.values())
    fig, axes = plt.subplots(
        1, len(panels), figsize=(5.5 * len(panels), 0.9 + 0.45 * rows), squeeze=False, sharey=False
    )
    for ax, (name, counts) in zip(axes[0], panels.items()):
        labels = [f"{c.method} ({c.episodes})" for c in counts][::-1]
        left = [0.0] * len(counts)
        for stage, color in zip(stages, colors):
            share = [100.0 * c.counts[stage] / c.episodes for c in counts][::-1]
            ax.barh(labels, share, left=left, color=color, edgecolor="white", label=stage)
            for y, (x0, w) in enumerate(zip(left, share)):
                if w >= 8:
                    ax.text(
                        x0 + w / 2,
                        y,
                        f"{w:.0f}",
                        ha="center",
                        va="center",
                        fontsize=8,
                        color="white" if sum(color[:3]) < 1.5 else "black",
                    )  # readable on dark segments
            left = [a + b for a, b in zip(left, share)]
        ax.set_xlim(0, 100)
        ax.set_xlabel(xlabel)
        ax.set_title(name, fontsize=10)
    axes[0][-1].legend(loc="upper left", bbox_to_anchor=(1.05, 1.0), fontsize=8, title="stage", title_fontsize=8)
    if title:
        fig.suptitle(title)
    return save_figure(fig, path)
