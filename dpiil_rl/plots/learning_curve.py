"""Success against cumulative expert actions, one point per iteration (paper Fig. 3(c) bottom, one run)."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def plot_learning_curve(metrics: Sequence[dict[str, Any]], path: str | Path, title: str = "") -> Path:
    evaluated = [m for m in metrics if m.get("autonomous_success") is not None]  # protocol.eval_every may skip some
    x = [m["expert_actions"] for m in evaluated]
    auto = [m["autonomous_success"] for m in evaluated]
    inter = [
        (m["expert_actions"], m["interactive_success"]) for m in metrics if m.get("interactive_success") is not None
    ]
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(10, 3.8))
    ax.plot(x, auto, "o-", color="tab:blue", label="autonomous (robot alone)")
    if inter:
        ax.plot(*zip(*inter), "s--", color="tab:orange", label="interactive (this iteration)")
    for m in evaluated:
        ax.annotate(
            f"k={m['iteration']}",
            (m["expert_actions"], m["autonomous_success"]),
            fontsize=7,
            textcoords="offset points",
            xytext=(2, 4),
        )
    ax.set_xlabel("cumulative expert actions")
    ax.set_ylabel("success rate")
    ax.set_ylim(-0.03, 1.03)
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right", fontsize=8)
    it = [m["iteration"] for m in metrics]
    bx.bar([i - 0.2 for i in it], [m["interventions"] for m in metrics], width=0.4, label="interventions")
    bx.bar([i + 0.2 for i in it], [m["collisions"] for m in metrics], width=0.4, label="collisions (interactive)")
    bx.set_xlabel("iteration k")
    bx.set_xticks(it)
    bx.legend(fontsize=8)
    bx.grid(alpha=0.3, axis="y")
    fig.suptitle(title)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
