"""The ring-safety tables (:mod:`dpiil_rl.study.ring_safety`) as markdown: one section per question.

Every cell over seeds is ``mean [95% bootstrap CI]`` (no interval with one seed); pooled per-step samples
(risk relative to χ) are quantiles. Differences between methods or studies are Welch intervals
(:func:`~dpiil_rl.study.intervals.welch_interval`), undefined with fewer than 2 seeds on a side.
"""

from __future__ import annotations

import math
from collections import Counter
from typing import Callable, Sequence

import numpy as np

from dpiil_rl.study.intervals import welch_interval
from dpiil_rl.study.ring_safety import (
    ALL,
    SPEED_BINS,
    WINDOW,
    FailedEpisode,
    MethodSafety,
    RunSafety,
    handover_curve,
    mean_ci,
)

#: quantiles of the risk relative to χ
QUANTILES = (0.1, 0.5, 0.9, 0.99)
#: bounds (cm/step) between a still, a slow and a moving robot over a failed episode's last robot-driven steps
SPEED_CLASSES = (0.1, 0.5)


def cell(values: Sequence[float], digits: int = 1, scale: float = 1.0) -> str:
    """``mean [low, high]`` over seeds (``mean (1 seed)`` with one, ``–`` with none)."""
    mean, low, high = mean_ci([scale * v for v in values])
    if math.isnan(mean):
        return "–"
    if math.isnan(low):
        return f"{mean:.{digits}f} (1 seed)"
    return f"{mean:.{digits}f} [{low:.{digits}f}, {high:.{digits}f}]"


def interval(a: Sequence[float], b: Sequence[float], digits: int = 1, scale: float = 1.0) -> str:
    """``difference [Welch 95% CI]`` of ``mean(a) − mean(b)``; the CI needs 2 seeds on each side."""
    if not len(a) or not len(b):
        return "–"
    diff = scale * (float(np.mean(a)) - float(np.mean(b)))
    low, high = welch_interval([scale * v for v in a], [scale * v for v in b])
    if math.isnan(low):
        return f"{diff:+.{digits}f} (no CI: {len(a)} and {len(b)} seeds)"
    return f"{diff:+.{digits}f} [{low:+.{digits}f}, {high:+.{digits}f}]"


def _table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    return ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)] + ["| " + " | ".join(r) + " |" for r in rows]


def _stage_keys(groups: Sequence[MethodSafety]) -> list[int]:
    """Every step (:data:`ALL`) and each stage some run's interactive steps were in."""
    seen = sorted({k for g in groups for r in g.staged_runs() for k in r.steps if k != ALL})
    return [ALL] + seen


def _stage_name(groups: Sequence[MethodSafety], key: int) -> str:
    return "all steps" if key == ALL else groups[0].stages[key]


def _seeds(group: MethodSafety, key: int) -> str:
    runs = len(group.runs_for(key))
    return f"{runs} of {len(group.interactive)}" if key != ALL else str(runs)


def headline_section(groups: Sequence[MethodSafety]) -> list[str]:
    rows = []
    for g in groups:
        runs = g.interactive
        if not runs:
            continue
        agreement = [r.gate_agreement for r in runs]
        gate = (
            "yes"
            if all(r.threshold_gate for r in runs)
            else ("no" if all(math.isnan(a) or a < 1.0 for a in agreement) else "in some runs")
        )
        rows.append(
            [
                g.study,
                g.method,
                str(len(runs)),
                f"{sum(r.episodes for r in runs):,} ({sum(sum(r.failures.values()) for r in runs)} failed)",
                cell([r.success for r in runs], scale=100.0),
                cell([100.0 * sum(r.failures.values()) / r.episodes for r in runs]),
                cell([100.0 * sum(r.contacts.values()) / r.episodes for r in runs]),
                cell([float(sum(r.contact_steps.values())) for r in runs]),
                cell(g.expert_share(ALL), scale=100.0),
                gate,
            ]
        )
    header = [
        "study",
        "method",
        "seeds",
        "interactive episodes",
        "interactive success %",
        "failed episodes per 100",
        "episodes with a contact per 100",
        "contact steps per run",
        "expert-mode steps %",
        "gate = risk > χ",
    ]
    return (
        ["### Interactive episodes", ""]
        + _table(header, rows)
        + [
            "",
            "Per 100 interactive episodes of the run (methods run different numbers of episodes for the same "
            "1,000 expert pairs per iteration). *gate = risk > χ*: every interactive step was in expert mode "
            "exactly when its recorded risk exceeded the χ calibrated after the previous iteration.",
            "",
        ]
    )


def gap_section(groups: Sequence[MethodSafety], reference: str) -> list[str]:
    """Each method against ``reference`` in the same study, and each method against itself in the first study."""
    lines = []
    success: Callable[[MethodSafety], list[float]] = lambda g: [r.success for r in g.interactive]  # noqa: E731
    failed: Callable[[MethodSafety], list[float]] = lambda g: [  # noqa: E731
        100.0 * sum(r.failures.values()) / r.episodes for r in g.interactive
    ]
    ref = {g.study: g for g in groups if g.method == reference and g.interactive}
    rows = [
        [g.study, g.method, reference, interval(success(g), success(ref[g.study]), scale=100.0)]
        + [interval(failed(g), failed(ref[g.study]))]
        for g in groups
        if g.interactive and g.method != reference and g.study in ref
    ]
    if rows:
        header = ["study", "method", "against", "Δ interactive success (points)", "Δ failed episodes per 100"]
        lines += [f"### Against {reference}, same study", ""] + _table(header, rows) + [""]
    studies = list(dict.fromkeys(g.study for g in groups))
    first = {g.method: g for g in groups if g.study == studies[0] and g.interactive}
    rows = [
        [g.method, g.study, studies[0], interval(success(g), success(first[g.method]), scale=100.0)]
        + [interval(failed(g), failed(first[g.method]))]
        for g in groups
        if g.study != studies[0] and g.interactive and g.method in first
    ]
    if rows:
        header = ["method", "study", "against", "Δ interactive success (points)", "Δ failed episodes per 100"]
        lines += [f"### Against the same method in {studies[0]}", ""] + _table(header, rows) + [""]
    if lines:
        lines += ["Mean difference over seeds and its Welch 95% interval.", ""]
    return lines


def stage_outcome_section(groups: Sequence[MethodSafety]) -> list[str]:
    """Failed episodes and episodes with a contact by their furthest stage."""
    groups = [g for g in groups if g.interactive]
    if not groups:
        return []
    stages = groups[0].stages
    rows = []
    for g in groups:
        fails = [f"{cell(g.failure_rate(s), 2)} ({sum(r.failures[s] for r in g.interactive)})" for s in stages]
        contacts = [
            f"{cell(g.contact_rate(s), 2)} ({sum(r.contacts[s] for r in g.interactive)}; "
            f"{sum(r.contact_steps[s] for r in g.interactive)} steps)"
            for s in stages
        ]
        rows.append([g.study, g.method, "failed"] + fails[:-1])  # a threaded episode did not fail
        rows.append([g.study, g.method, "contact"] + contacts)
    header = ["study", "method", "episodes"] + list(stages)
    # the failure rows have one cell fewer (no failure is threaded): pad them
    width = len(header)
    rows = [r + ["–"] * (width - len(r)) for r in rows]
    return (
        ["### By the furthest stage of the episode", ""]
        + _table(header, rows)
        + [
            "",
            "Per 100 interactive episodes (mean [95% CI] over seeds), in brackets the episodes pooled over seeds "
            "(and their contact steps). Contacts are recorded per episode, not per step: a contact in an episode "
            "that reached *threaded* happened somewhere on the way, not necessarily at the peg.",
            "",
        ]
    )


def _speed_classes() -> list[tuple[str, float, float]]:
    bounds = (0.0,) + SPEED_CLASSES + (math.inf,)
    names = ("still", "slow", "moving")
    return [(name, lo, hi) for name, lo, hi in zip(names, bounds[:-1], bounds[1:])]


def _failed_row(
    study: str, method: str, stage: str, failed: Sequence[FailedEpisode], stages: Sequence[str]
) -> list[str]:
    auto = [f.final_auto for f in failed]
    alone = [f for f in failed if math.isfinite(f.final_speed)]
    cells = []
    for _, lo, hi in _speed_classes():
        mine = [f for f in alone if lo <= f.final_speed < hi]
        ratios = [f.final_risk_ratio for f in mine if math.isfinite(f.final_risk_ratio)]
        cells.append(f"{len(mine)} ({np.median(ratios):.2f})" if ratios else str(len(mine)))
    last = Counter(f.last_stage for f in failed if f.last_stage is not None)
    return [
        study,
        method,
        stage,
        str(len(failed)),
        f"{100 * float(np.median([f.expert_share for f in failed])):.0f}%",
        f"{np.median(auto):.0f} ({np.quantile(auto, 0.25):.0f}–{np.quantile(auto, 0.75):.0f})",
        str(len(alone)),
        " / ".join(cells) if alone else "–",
        ", ".join(f"{s} {last[s]}" for s in stages if last[s]) or "–",
    ]


def failed_episode_section(groups: Sequence[MethodSafety]) -> list[str]:
    """Failed interactive episodes per (study, method), all and by their furthest stage: how long the gate left
    the robot alone at their end, and how fast the robot moved and how high the risk was as they ran out."""
    rows = []
    for g in groups:
        failed = [f for r in g.interactive for f in r.failed]
        if not failed:
            continue
        rows.append(_failed_row(g.study, g.method, "all", failed, g.stages))
        for stage in g.stages:
            mine = [f for f in failed if f.stage == stage]
            if mine:
                rows.append(_failed_row(g.study, g.method, stage, mine, g.stages))
    if not rows:
        return []
    classes = " / ".join(
        f"{name} (≥ {lo:g})" if math.isinf(hi) else f"{name} (< {hi:g})" if lo == 0 else f"{name} ({lo:g}–{hi:g})"
        for name, lo, hi in _speed_classes()
    )
    header = [
        "study",
        "method",
        "furthest stage",
        "failed episodes",
        "expert-mode steps (median)",
        "robot alone at the end: steps, median (IQR)",
        f"robot alone for the last {WINDOW} steps",
        f"of those, by the robot's speed then (cm/step): {classes}",
        "stage of the last step",
    ]
    return (
        ["### Failed interactive episodes", ""]
        + _table(header, rows)
        + [
            "",
            "Pooled over seeds. *Robot alone at the end*: the steps before the 200-step limit in which the gate "
            "kept the robot in control (0: the expert had control as the episode ran out). For the episodes "
            f"whose last {WINDOW} steps the robot drove: how many were still, slow or moving (its median speed over "
            "those steps) and, in brackets, the median over them of the gate's median risk / χ in those steps "
            "(threshold gates only; below 1 the gate stays quiet). *Stage of the last step*: runs with per-step "
            "stages only.",
            "",
        ]
    )


def expert_share_section(groups: Sequence[MethodSafety]) -> list[str]:
    groups = [g for g in groups if g.interactive]
    if not groups:
        return []
    keys = _stage_keys(groups)
    header = ["study", "method", "seeds with per-step stages"] + [_stage_name(groups, k) for k in keys]
    rows = [
        [g.study, g.method, f"{len(g.staged_runs())} of {len(g.interactive)}"]
        + [cell(g.expert_share(k), scale=100.0) for k in keys]
        for g in groups
    ]
    return ["### Share of steps in expert mode, by stage of the state (%)", ""] + _table(header, rows) + [""]


def risk_section(groups: Sequence[MethodSafety]) -> list[str]:
    groups = [g for g in groups if g.interactive and all(r.threshold_gate for r in g.interactive)]
    if not groups:
        return []
    keys = _stage_keys(groups)
    header = ["study", "method"] + [_stage_name(groups, k) for k in keys]
    rows = []
    for g in groups:
        cells = []
        for k in keys:
            ratio = g.pooled("risk_ratio", k)
            if not ratio.size:
                cells.append("–")
                continue
            q = " / ".join(f"{v:.2g}" for v in np.quantile(ratio, QUANTILES))
            cells.append(f"{q} ({100 * float((ratio > 1).mean()):.0f}% > 1)")
        rows.append([g.study, g.method] + cells)
    return (
        ["### The gate's risk relative to its threshold χ, by stage", ""]
        + _table(header, rows)
        + [
            "",
            "Quantiles " + " / ".join(f"{q:g}" for q in QUANTILES) + " of risk / χ over every interactive step "
            "(pooled over seeds; per-stage columns from the runs with per-step stages); > 1 is expert mode. "
            "Only gates that are exactly risk > χ.",
            "",
        ]
    )


def speed_section(groups: Sequence[MethodSafety]) -> list[str]:
    groups = [g for g in groups if g.interactive]
    if not groups:
        return []
    keys = _stage_keys(groups)
    header = ["study", "method", "stage", "seeds", "hand-over rate %", "speed, handed over", "speed, kept driving"]
    header += ["Spearman(speed, risk)"]
    rows = []
    for g in groups:
        for k in keys:
            if not g.runs_for(k):
                continue
            rows.append(
                [
                    g.study,
                    g.method,
                    _stage_name(groups, k),
                    _seeds(g, k),
                    cell(g.handover_rate(k), scale=100.0),
                    cell(g.speed_median(k, True), 2),
                    cell(g.speed_median(k, False), 2),
                    cell(g.speed_risk_correlation(k), 2),
                ]
            )
    return (
        ["### The robot's own speed where the gate handed over", ""]
        + _table(header, rows)
        + [
            "",
            "At every interactive step whose previous step the robot drove: did the gate hand over, and the "
            "end-effector speed coming into the state (cm per control step, 20 steps per second; the state's "
            "joint velocities carry it, so the speed head can read it). Speeds are each seed's median; "
            "Spearman's correlation of that speed with the recorded risk, per seed. Mean [95% CI] over seeds.",
            "",
        ]
    )


def handover_by_speed_section(groups: Sequence[MethodSafety]) -> list[str]:
    """The hand-over curve of every method over all its interactive steps (the figure's first panel) as a table."""
    groups = [g for g in groups if g.interactive]
    if not groups:
        return []
    bins = [f"≥ {lo:g}" if math.isinf(hi) else f"{lo:g}–{hi:g}" for lo, hi in zip(SPEED_BINS[:-1], SPEED_BINS[1:])]
    rows = []
    for g in groups:
        cells = [f"{100 * share:.1f}% ({n:,})" if n else "–" for _, share, n in handover_curve(g, ALL)]
        rows.append([g.study, g.method, str(len(g.interactive))] + cells)
    return (
        ["### Hand-over rate by the robot's own speed, all steps (cm/step)", ""]
        + _table(["study", "method", "seeds"] + bins, rows)
        + [
            "",
            "Per bin of the robot's speed into the state, pooled over seeds: the share of robot-driven steps at "
            "which the gate handed over (and the number of such steps).",
            "",
        ]
    )


def ring_safety_markdown(groups: Sequence[MethodSafety], reference: str, command: str = "") -> str:
    """Every section, with the command that made it (when given) as a first line."""
    lines = ["## Ring: where the gates were unsafe while learning", ""]
    if command:
        lines += [f"Made by `{command}` from the runs' committed records.", ""]
    lines += headline_section(groups)
    lines += gap_section(groups, reference)
    lines += stage_outcome_section(groups)
    lines += failed_episode_section(groups)
    lines += expert_share_section(groups)
    lines += risk_section(groups)
    lines += speed_section(groups)
    lines += handover_by_speed_section(groups)
    unstaged = [f"{g.study}/{g.method} ({len(g.interactive) - len(g.staged_runs())})" for g in groups]
    unstaged = [u for u, g in zip(unstaged, groups) if len(g.staged_runs()) < len(g.interactive)]
    if unstaged:
        lines += [
            "Runs whose paths have no per-step stages (recorded before they existed) count in *all steps* only: "
            + ", ".join(unstaged)
            + ".",
            "",
        ]
    return "\n".join(lines)


def runs_line(runs: Sequence[RunSafety]) -> str:
    """``study: method seeds, ...`` of the runs read (for the command's output)."""
    by: dict[tuple[str, str], list[int]] = {}
    for r in runs:
        by.setdefault((r.study, r.method), []).append(r.seed)
    return "; ".join(f"{s}/{m}: seeds {sorted(v)}" for (s, m), v in by.items())
