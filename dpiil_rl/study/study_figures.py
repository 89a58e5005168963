"""Figures of a study across methods and seeds (paper Fig. 3(c) top and bottom, Fig. 3(d)), as PNG.

The functions take plain numbers (success as fractions 0–1, paper values in percent) so they can be
drawn from any source; :mod:`dpiil_rl.study.study_report` feeds them the recomputed run numbers.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Mapping, Sequence, cast

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from dpiil_rl.plots.figure_io import save_figure  # noqa: E402
from dpiil_rl.study.study_runs import METHOD_ORDER, method_order  # noqa: E402
from dpiil_rl.study.study_stats import ChiFit, ChiPoint, significance_stars  # noqa: E402

Row = dict[str, Any]


def method_color(method: str) -> Any:
    """One colour per method, the same in every figure (known methods by their place in METHOD_ORDER,
    so no two of them share one; others by a stable hash)."""
    # listed colormaps: their colors are tuples of RGB tuples (matplotlib types them as any colour data)
    tab10, tab20 = cast(Any, plt.get_cmap("tab10")), cast(Any, plt.get_cmap("tab20"))
    palette = tab10.colors + tuple(tab20.colors[1::2])  # 20 distinct colours
    index = METHOD_ORDER.index(method) if method in METHOD_ORDER else len(METHOD_ORDER) + sum(map(ord, method))
    return palette[index % len(palette)]


def interactive_boxplot(
    values: Mapping[str, Sequence[float]],
    p_values: Mapping[str, float],
    reference: str,
    path: str | Path,
    paper: Mapping[str, float | None] | None = None,
    title: str = "",
) -> Path:
    """Box plot of per-run interactive success per method with the seeds jittered on top; significance
    marks of the reference method against each other method, the paper's value as a diamond."""
    methods = [m for m in method_order(values) if values[m]]
    fig, ax = plt.subplots(figsize=(1.3 * max(len(methods), 2) + 1.5, 4.2))
    data = [100 * np.asarray(values[m], dtype=float) for m in methods]
    if methods:
        ax.boxplot(
            data,
            positions=range(len(methods)),
            widths=0.55,
            showfliers=False,
            medianprops={"color": "k"},
            boxprops={"color": "0.3"},
        )
    rng = np.random.default_rng(0)
    for i, (method, y) in enumerate(zip(methods, data)):
        ax.scatter(i + rng.uniform(-0.14, 0.14, len(y)), y, s=16, color=method_color(method), zorder=3, alpha=0.85)
        if method != reference and method in p_values:
            ax.annotate(significance_stars(p_values[method]), (i, min(y.max() + 3, 107)), ha="center", fontsize=9)
        if paper and paper.get(method) is not None:
            ax.scatter(
                [i + 0.32],
                [cast(float, paper[method])],
                marker="D",
                s=30,
                facecolor="none",
                edgecolor="tab:red",
                zorder=4,
                label="paper" if "paper" not in ax.get_legend_handles_labels()[1] else None,
            )
    ax.set_xticks(range(len(methods)), methods, rotation=20, fontsize=8)
    ax.set_ylabel("interactive success (%)")
    ax.set_ylim(-3, 112)
    ax.grid(alpha=0.3, axis="y")
    if ax.get_legend_handles_labels()[1]:
        ax.legend(loc="lower right", fontsize=8)
    ax.set_title((title + "   " if title else "") + f"marks: {reference} vs each (Welch t-test)", fontsize=9)
    if not methods:
        ax.text(0.5, 0.5, "no interactive runs", ha="center", transform=ax.transAxes)
    return save_figure(fig, path)


def mean_curve(curves: Sequence[Sequence[Row]], y_key: str = "autonomous_success") -> dict[str, np.ndarray]:
    """Per iteration: mean expert actions, mean and sample std of ``y_key`` over the runs that reached it."""
    by_iteration: dict[int, list[Row]] = {}
    for curve in curves:
        for row in curve:
            if row.get(y_key) is not None:
                by_iteration.setdefault(int(row["iteration"]), []).append(row)
    its = sorted(by_iteration)
    x = np.array([np.mean([r["expert_actions"] for r in by_iteration[k]]) for k in its], dtype=float)
    ys = [np.array([r[y_key] for r in by_iteration[k]], dtype=float) for k in its]
    return {
        "iteration": np.array(its, dtype=int),
        "x": x,
        "mean": np.array([y.mean() for y in ys]),
        "std": np.array([y.std(ddof=1) if len(y) > 1 else 0.0 for y in ys]),
        "n": np.array([len(y) for y in ys]),
    }


def autonomous_vs_expert_actions(
    curves: Mapping[str, Sequence[Sequence[Row]]],
    path: str | Path,
    paper: Mapping[str, float | None] | None = None,
    title: str = "",
) -> Path:
    """Autonomous success against cumulative expert actions, mean ± std over seeds (shaded) per method;
    the paper's final value as a hollow marker at the method's last mean x."""
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for method in method_order(curves):
        c = mean_curve(curves[method])
        if not len(c["x"]):
            continue
        color = method_color(method)
        ax.plot(c["x"], 100 * c["mean"], "o-", ms=3.5, color=color, label=f"{method} (n={int(c['n'].max())})")
        low, high = (
            np.clip(c["mean"] - c["std"], 0, 1),
            np.clip(c["mean"] + c["std"], 0, 1),
        )  # shading kept in [0, 100]%
        ax.fill_between(c["x"], 100 * low, 100 * high, color=color, alpha=0.15, lw=0)
        if paper and paper.get(method) is not None:
            ax.scatter(
                [c["x"][-1]],
                [cast(float, paper[method])],
                marker="D",
                s=30,
                facecolor="none",
                edgecolor=color,
                zorder=4,
            )
    ax.set_xlabel("cumulative expert actions")
    ax.set_ylabel("autonomous success (%)")
    ax.set_ylim(-3, 105)
    ax.grid(alpha=0.3)
    if ax.get_legend_handles_labels()[1]:
        ax.legend(fontsize=7, loc="lower right")
    ax.set_title(
        (title + "   " if title else "") + "mean ± std over seeds" + ("; ◇ paper" if paper else ""), fontsize=9
    )
    return save_figure(fig, path)


def chi_sensitivity(points: Sequence[ChiPoint], fits: Sequence[ChiFit], path: str | Path, title: str = "") -> Path:
    """Interactive and autonomous success against a fixed χ (log axis), mean ± std over seeds per χ,
    one line per method, r² of log10(χ) vs success (every run a point) in the legend; titled as the paper's
    figure, since its raw χ means a different share of risky states for each gate."""
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.9), sharey=True)
    r2 = {(f.method, f.field): f.r_squared for f in fits}
    for ax, field, label in zip(axes, ("interactive_success", "autonomous_success"), ("interactive", "autonomous")):
        for method in method_order(p.method for p in points):
            pts = [p for p in points if p.method == method and p.values.get(field) is not None]
            if not pts:
                continue
            chi = np.array([p.chi for p in pts])
            mean = np.array([100 * p.values[field].mean for p in pts])  # type: ignore[union-attr]
            std = np.array([0.0 if math.isnan(p.values[field].std) else 100 * p.values[field].std for p in pts])  # type: ignore[union-attr]
            fit = r2.get((method, field), math.nan)
            color = method_color(method)
            ax.errorbar(
                chi,
                mean,
                yerr=std,
                fmt="o-",
                ms=4,
                capsize=3,
                color=color,
                label=f"{method} (r² = {'n/a' if math.isnan(fit) else f'{fit:.2f}'})",
            )
        ax.set_xscale("log")
        ax.set_xlabel("χ (fixed threshold)")
        ax.set_title(f"{label} success", fontsize=9)
        ax.grid(alpha=0.3, which="both")
        if ax.get_legend_handles_labels()[1]:
            ax.legend(fontsize=8, loc="lower left")
    axes[0].set_ylabel("success (%)")
    axes[0].set_ylim(-3, 105)
    label = (
        "the paper's Fig. 3(d): one raw χ grid for every gate, whose risks are in different units "
        "(the unit-free version: knob_sensitivity.png of a frontier study)"
    )
    fig.suptitle(f"{title}: {label}" if title else label, fontsize=9)
    return save_figure(fig, path)
