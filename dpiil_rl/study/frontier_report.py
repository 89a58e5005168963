"""The frontier part of a study report: ``frontier.md`` and the frontier figures, written when the study holds
runs of methods over their knobs (``make frontier``); nothing otherwise."""

from __future__ import annotations

import math
from dataclasses import asdict
from pathlib import Path
from typing import Any, Sequence

from dpiil_rl.study.frontier import (
    EFFORTS,
    LEVELS,
    MatchedComparison,
    area_under_frontier,
    frontier_groups,
    frontier_points,
    matched_effort,
)
from dpiil_rl.study.frontier_figures import frontier_figure, frontier_overview, knob_sensitivity
from dpiil_rl.study.frontier_robustness import ALPHA, Verdict, min_adjusted, verdicts
from dpiil_rl.study.study_runs import StudyRun, select

OUTCOME_LABELS = {"interactive_success": "interactive success", "collisions": "interactive collisions per run"}


def _pct(x: float) -> str:
    return "–" if math.isnan(x) else f"{100 * x:.1f}%"


def _num(x: float, digits: int = 1) -> str:
    return "–" if math.isnan(x) else f"{x:.{digits}f}"


def _value(outcome: str, x: float) -> str:
    return _pct(x) if outcome.endswith("success") else _num(x)


def _diff(outcome: str, c: MatchedComparison) -> str:
    if math.isnan(c.diff):
        return "–"
    scale, unit = (100.0, " pts") if outcome.endswith("success") else (1.0, "")
    lo, hi = c.diff_ci
    interval = "" if math.isnan(lo) else f" [{scale * lo:+.1f}, {scale * hi:+.1f}]"
    return f"{scale * c.diff:+.1f}{unit}{interval}"


def _p(p: float) -> str:
    return "–" if math.isnan(p) else f"{p:.2g}"


def _seeds(n: float) -> str:
    return "–" if math.isnan(n) else ("> 100,000" if math.isinf(n) else f"{int(n)}")


def _table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    return ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)] + ["| " + " | ".join(r) + " |" for r in rows]


def _comparison_rows(rows: Sequence[MatchedComparison], outcome: str) -> list[list[str]]:
    out = []
    for c in rows:
        lo, hi = c.ci
        interval = "" if math.isnan(lo) else f" [{_value(outcome, lo)}, {_value(outcome, hi)}]"
        level = "AUF" if math.isnan(c.level) else f"{100 * c.level:.0f}%"
        out.append(
            [
                level,
                c.method,
                str(c.n),
                f"{_value(outcome, c.mean)}{interval}",
                _diff(outcome, c) if c.method != c.reference else "ref",
                str(c.pairs) if c.method != c.reference else "–",
                _p(c.p_value),
                _seeds(c.seeds_needed),
            ]
        )
    return out


def frontier_section(
    runs: Sequence[StudyRun], out: Path, envs: Sequence[str], reference: str = "dpiil_ucb"
) -> tuple[dict[str, Path], dict[str, Any]]:
    """Write ``frontier.md`` and the figures into ``out``; returns ``(files, data for stats.json)``."""
    groups = frontier_groups(runs)
    if not groups:
        return {}, {}
    points = frontier_points(runs)
    matched = matched_effort(runs, reference=reference)
    ranges, auf = area_under_frontier(runs, reference=reference)
    files: dict[str, Path] = {}
    lines = [
        "# The safety–effort frontier",
        "",
        "Every method over its own unit-free knob (`frontier:` in `configs/method/<method>.yaml`), every point the "
        "mean over seeds with a bootstrap 95% interval, recomputed from each run's `episodes.jsonl`. *Expert share*: "
        "the share of interactive steps the expert drove; *queries*: steps at which the expert had to act or judge "
        "(monitoring included); *expert actions*: labels in D, demos included.",
        "",
    ]
    shown = [e for e in envs if any(g[0] == e for g in groups)]
    if len(shown) > 1:
        files["frontier_overview.png"] = frontier_overview(points, shown, out / "frontier_overview.png")
        lines += ["![every geometry](frontier_overview.png)", ""]
    for env in shown:
        stem = "" if len(envs) == 1 else f"_{env}"
        env_points = [p for p in points if p.env == env]
        for effort, name in zip(EFFORTS, ("frontier", "frontier_queries", "frontier_actions")):
            files[f"{name}{stem}.png"] = frontier_figure(env_points, effort, out / f"{name}{stem}.png", title=env)
        quantile_methods = sorted(
            {
                m
                for (e, m), by in groups.items()
                if e == env
                and str(select(next(iter(by.values()))[0].config_data, "method.frontier.key", default="")).endswith(
                    "threshold.quantile"
                )
            }
        )
        if quantile_methods:
            files[f"knob_sensitivity{stem}.png"] = knob_sensitivity(
                env_points, quantile_methods, out / f"knob_sensitivity{stem}.png", title=env
            )
        lines += [f"## {env}", "", f"![frontier](frontier{stem}.png)", ""]
        lines += _table(
            [
                "method",
                "knob",
                "seeds",
                "expert share",
                "queries",
                "expert actions",
                "interactive success",
                "per-iteration mean",
                "collisions per run",
                "autonomous (final)",
            ],
            [
                [
                    p.method,
                    f"{p.knob:g}",
                    str(p.seeds),
                    _pct(p.effort["expert_share"]),
                    _pct(p.effort["query_share"]),
                    _num(p.effort["expert_actions"], 0),
                    f"{_pct(p.outcome['interactive_success'][0])} "
                    f"[{_pct(p.outcome['interactive_success'][1])}, {_pct(p.outcome['interactive_success'][2])}]",
                    _pct(p.outcome["interactive_success_iter_mean"][0]),
                    f"{_num(p.outcome['collisions'][0])} "
                    f"[{_num(p.outcome['collisions'][1])}, {_num(p.outcome['collisions'][2])}]",
                    _pct(p.outcome["autonomous_success"][0]),
                ]
                for p in env_points
            ],
        )
        for outcome in ("interactive_success", "collisions"):
            rows = [c for c in matched if c.env == env and c.outcome == outcome]
            lines += [
                "",
                f"### {OUTCOME_LABELS[outcome]} at matched expert share ({env})",
                "",
                f"Each seed's curve interpolated at {', '.join(f'{100 * x:.0f}%' for x in LEVELS)} expert share (no "
                f"extrapolation: *n* counts the seeds that reach the level); Δ = {reference} − method over the "
                "seeds both have, with the paired t-test and its 95% interval; *seeds for power 0.8*: pairs a "
                "paired t-test needs to resolve the observed Δ at α = 0.05.",
                "",
            ]
            lines += _table(
                [
                    "expert share",
                    "method",
                    "n",
                    "mean [95% CI]",
                    f"Δ {reference} − method [95% CI]",
                    "pairs",
                    "p",
                    "seeds for power 0.8",
                ],
                _comparison_rows(rows, outcome),
            )
        rows = [c for c in auf if c.env == env]
        lines += ["", f"### Area under the frontier ({env})", ""]
        if rows:
            lines += [
                f"Interactive success averaged, per seed, over the expert shares every seed of the method and of "
                f"{reference} reaches (the range in the first column; {reference}'s own row: over its own range).",
                "",
            ]
            lines += _table(
                [
                    "expert shares",
                    "method",
                    "n",
                    "mean [95% CI]",
                    f"Δ {reference} − method [95% CI]",
                    "pairs",
                    "p",
                    "seeds for power 0.8",
                ],
                [
                    [f"{100 * c.effort_range[0]:.1f}–{100 * c.effort_range[1]:.1f}%", *row[1:]]
                    for c, row in zip(rows, _comparison_rows(rows, "interactive_success"))
                ],
            )
        missing = [m for (e, m), (lo, hi) in ranges.items() if e == env and not lo < hi]
        if missing:
            lines += [
                "",
                f"No area for {', '.join(missing)}: no effort range is covered by every seed of it and of "
                f"{reference} (see the figure).",
            ]
        lines.append("")
    judged = verdicts(matched, auf, reference)
    lines += robustness_lines(judged, reference)
    (out / "frontier.md").write_text("\n".join(lines) + "\n")
    files["frontier.md"] = out / "frontier.md"
    data = {
        "frontier_points": [asdict(p) for p in points],
        "matched_effort": [asdict(c) for c in matched],
        "area_under_frontier": [asdict(c) for c in auf],
        "frontier_ranges": {f"{e}/{m}": list(v) for (e, m), v in ranges.items()},
        "robustness": [
            {**asdict(v), "gaps": [asdict(c) for c in v.gaps], "min_adjusted_p": min_adjusted(v)} for v in judged
        ],
    }
    return files, data


def _gap(v: Verdict, level: float) -> str:
    for c, a in zip(v.gaps, v.adjusted):
        if (math.isnan(level) and math.isnan(c.level)) or c.level == level:
            return f"{_diff('interactive_success', c)} (p_Holm {_p(a)})"
    return "–"


def robustness_lines(judged: Sequence[Verdict], reference: str) -> list[str]:
    """The section that says, per geometry and method, whether the reference's advantage holds."""
    if not judged:
        return []
    lines = [
        f"## Where {reference}'s advantage at matched effort holds",
        "",
        f"Δ = {reference} − method in interactive success (points), paired over seeds, at each matched expert "
        "share and over the area under the frontier (AUF). The tests of one method against the reference on "
        "every geometry form one family; *p_Holm* is Holm-adjusted over it (m tests), and a verdict needs "
        f"p_Holm < {ALPHA:g}. *Seeds (AUF)*: pairs a paired t-test needs to resolve the observed AUF gap with "
        f"power 0.8 at α = {ALPHA:g}, and at α / m.",
        "",
    ]
    return lines + robustness_table(judged) + [""]


def robustness_table(judged: Sequence[Verdict]) -> list[str]:
    """The verdict table: per geometry and method, Δ at each matched share and over the AUF, and the verdict."""
    rows = []
    for v in judged:
        rows.append(
            [
                v.env,
                v.method,
                *(_gap(v, level) for level in LEVELS),
                _gap(v, math.nan),
                f"{_seeds(v.seeds_auf)} / {_seeds(v.seeds_auf_family)} (m = {v.family})",
                f"**{v.verdict}**",
            ]
        )
    return _table(
        [
            "geometry",
            "method",
            *(f"Δ at {100 * x:.0f}% share" for x in LEVELS),
            "Δ AUF",
            "seeds (AUF) α / α÷m",
            "verdict",
        ],
        rows,
    )
