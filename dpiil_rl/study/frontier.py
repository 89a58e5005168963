"""The safety–effort frontier of a study: each method's outcomes against the person's effort, at matched effort.

A frontier study runs every method over its own knob (:mod:`dpiil_rl.methods.frontier_knob`) and seeds;
a run's knob value is read back from its resolved config (``method.frontier.key``). From the runs'
recomputed summaries:

- :func:`frontier_points`: per (env, method, knob value), the mean effort and the mean outcome over seeds
  with a bootstrap 95% interval — the curves of the figure;
- :func:`matched_effort`: per seed, the method's curve (outcome against effort over its knob values) is
  interpolated linearly at fixed effort levels (e.g. 10%, 20%, 30% expert share; not extrapolated: a seed
  whose curve does not reach a level has no value there); methods are then compared with the reference
  at each level, pairing seeds (same seed: same start states and expert noise stream), with the paired
  t-test, the 95% interval of the mean difference and the seeds a power calculation asks for;
- :func:`area_under_frontier`: per seed, the mean of the interpolated outcome over a grid of levels that
  every seed of the method and of the reference reaches (the trapezoid rule), compared the same way.

Effort measures: ``expert_share`` (the share of interactive steps the expert drove, the default),
``query_share`` (steps at which the expert had to act or judge, monitoring included) and
``expert_actions`` (labels in D, demos included).
"""

from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass
from typing import Iterable, Sequence

import numpy as np
from scipy import stats

from dpiil_rl.study.intervals import bootstrap_ci, paired_interval, seeds_for_power_paired
from dpiil_rl.study.study_runs import StudyRun, method_order, select

EFFORTS = ("expert_share", "query_share", "expert_actions")
OUTCOMES = ("interactive_success", "interactive_success_iter_mean", "collisions", "autonomous_success")
LEVELS = (0.1, 0.2, 0.3)  # expert shares at which methods are compared


def knob_value(run: StudyRun) -> float | None:
    """The run's value of its method's frontier knob (None for a run without one)."""
    key = select(run.config_data, "method.frontier.key")
    if key is None:
        return None
    value = select(run.config_data, str(key))
    return None if value is None else float(value)


def frontier_groups(runs: Iterable[StudyRun]) -> dict[tuple[str, str], dict[float, list[StudyRun]]]:
    """``{(env, method): {knob value: runs}}`` for methods with at least two knob values (calibrated-χ runs)."""
    groups: dict[tuple[str, str], dict[float, list[StudyRun]]] = defaultdict(lambda: defaultdict(list))
    for run in runs:
        value = knob_value(run)
        if value is not None and run.chi_fixed is None:
            groups[(run.env, run.method)][value].append(run)
    return {k: dict(v) for k, v in groups.items() if len(v) >= 2}


@dataclass(frozen=True)
class FrontierPoint:
    env: str
    method: str
    knob: float
    seeds: int
    effort: dict[str, float]  # mean over seeds of each effort measure
    outcome: dict[str, tuple[float, float, float]]  # mean and bootstrap 95% interval over seeds


def _value(run: StudyRun, field: str) -> float | None:
    v = run.summary.get(field)
    return None if v is None else float(v)


def frontier_points(runs: Iterable[StudyRun]) -> list[FrontierPoint]:
    points = []
    for (env, method), by_knob in sorted(
        frontier_groups(runs).items(), key=lambda kv: (kv[0][0], method_order([kv[0][1]]))
    ):
        for knob, group in sorted(by_knob.items()):
            effort = {}
            for e in EFFORTS:
                vals = [v for r in group if (v := _value(r, e)) is not None]
                effort[e] = float(np.mean(vals)) if vals else math.nan
            outcome = {}
            for o in OUTCOMES:
                vals = [v for r in group if (v := _value(r, o)) is not None]
                lo, hi = bootstrap_ci(vals) if vals else (math.nan, math.nan)
                outcome[o] = (float(np.mean(vals)) if vals else math.nan, lo, hi)
            points.append(FrontierPoint(env, method, knob, len(group), effort, outcome))
    return points


def seed_curve(by_knob: dict[float, list[StudyRun]], seed: int, effort: str, outcome: str) -> list[tuple[float, float]]:
    """``(effort, outcome)`` of one seed over the knob values, sorted by effort."""
    pts = []
    for group in by_knob.values():
        for run in group:
            if run.seed == seed and (x := _value(run, effort)) is not None and (y := _value(run, outcome)) is not None:
                pts.append((x, y))
    return sorted(pts)


def interpolate(curve: Sequence[tuple[float, float]], level: float) -> float:
    """The outcome at effort ``level`` by linear interpolation between the curve's points; nan outside them.
    Points at equal effort are averaged first."""
    if not curve:
        return math.nan
    merged: dict[float, list[float]] = defaultdict(list)
    for x, y in curve:
        merged[x].append(y)
    xs = sorted(merged)
    ys = [float(np.mean(merged[x])) for x in xs]
    if level < xs[0] or level > xs[-1]:
        return math.nan
    return float(np.interp(level, xs, ys))


@dataclass(frozen=True)
class MatchedComparison:
    env: str
    level: float  # effort level (or the AUF's range label as nan)
    outcome: str
    method: str
    n: int  # seeds with a value
    mean: float
    ci: tuple[float, float]
    reference: str
    pairs: int  # seeds with a value for both
    diff: float  # mean over paired seeds of (reference − method)
    diff_ci: tuple[float, float]
    p_value: float
    seeds_needed: float
    differences: tuple[float, ...] = ()  # the paired per-seed differences (reference − method), seed order
    effort_range: tuple[float, float] = (math.nan, math.nan)  # AUF rows: the effort range averaged over


Paired = tuple[int, float, tuple[float, float], float, float, tuple[float, ...]]
NO_PAIRS: Paired = (0, math.nan, (math.nan, math.nan), math.nan, math.nan, ())


def _paired(ref: dict[int, float], other: dict[int, float]) -> Paired:
    """``(pairs, mean difference, its 95% interval, paired-t p, seeds for power 0.8, differences)``."""
    seeds = sorted(set(ref) & set(other))
    d = [ref[s] - other[s] for s in seeds]
    if len(d) < 2:
        return len(d), (float(np.mean(d)) if d else math.nan), (math.nan, math.nan), math.nan, math.nan, tuple(d)
    if float(np.std(d, ddof=1)) <= 1e-12 * max(1.0, abs(float(np.mean(d)))):  # constant differences: no spread to test
        p = 1.0 if float(np.mean(d)) == 0.0 else 0.0
    else:
        p = float(stats.ttest_rel([ref[s] for s in seeds], [other[s] for s in seeds]).pvalue)
    return len(d), float(np.mean(d)), paired_interval(d), p, seeds_for_power_paired(d), tuple(d)


def matched_effort(
    runs: Iterable[StudyRun],
    levels: Sequence[float] = LEVELS,
    effort: str = "expert_share",
    outcomes: Sequence[str] = ("interactive_success", "collisions"),
    reference: str = "dpiil_ucb",
) -> list[MatchedComparison]:
    groups = frontier_groups(runs)
    out = []
    for env in sorted({e for e, _ in groups}):
        methods = method_order(m for e, m in groups if e == env)
        for outcome in outcomes:
            for level in levels:
                values = {}
                for m in methods:
                    by_knob = groups[(env, m)]
                    seeds = sorted({r.seed for g in by_knob.values() for r in g})
                    values[m] = {
                        s: v
                        for s in seeds
                        if not math.isnan(v := interpolate(seed_curve(by_knob, s, effort, outcome), level))
                    }
                for m in methods:
                    vals = list(values[m].values())
                    ci = bootstrap_ci(vals) if vals else (math.nan, math.nan)
                    paired = (
                        NO_PAIRS if m == reference or reference not in values else _paired(values[reference], values[m])
                    )
                    out.append(
                        MatchedComparison(
                            env,
                            level,
                            outcome,
                            m,
                            len(vals),
                            float(np.mean(vals)) if vals else math.nan,
                            ci,
                            reference,
                            *paired,
                        )
                    )
    return out


def common_range(
    groups: dict[tuple[str, str], dict[float, list[StudyRun]]],
    env: str,
    effort: str,
    methods: Sequence[str] | None = None,
) -> tuple[float, float]:
    """The effort range every seed of ``methods`` (default: every method) of ``env`` covers (low > high: none)."""
    lo, hi = -math.inf, math.inf
    for (e, m), by_knob in groups.items():
        if e != env or (methods is not None and m not in methods):
            continue
        for s in {r.seed for g in by_knob.values() for r in g}:
            xs = [x for x, _ in seed_curve(by_knob, s, effort, "interactive_success")]
            if xs:
                lo, hi = max(lo, min(xs)), min(hi, max(xs))
    return lo, hi


def _seed_areas(
    by_knob: dict[float, list[StudyRun]], effort: str, outcome: str, lo: float, hi: float, points: int
) -> dict[int, float]:
    grid = np.linspace(lo, hi, points)
    out = {}
    for s in sorted({r.seed for g in by_knob.values() for r in g}):
        curve = seed_curve(by_knob, s, effort, outcome)
        ys = [interpolate(curve, float(x)) for x in grid]
        if not any(math.isnan(y) for y in ys):
            out[s] = float(np.trapz(ys, grid) / (hi - lo))
    return out


def area_under_frontier(
    runs: Iterable[StudyRun],
    effort: str = "expert_share",
    outcome: str = "interactive_success",
    reference: str = "dpiil_ucb",
    points: int = 21,
) -> tuple[dict[tuple[str, str], tuple[float, float]], list[MatchedComparison]]:
    """``({(env, method): (low, high)}, comparisons)``: per seed, the mean interpolated outcome over an effort
    range, compared with the reference's (``level`` = nan in the rows). Each method is compared over the range
    every seed of it *and* of the reference covers (a gate whose curve starts at 30% share does not shrink the
    others' range); the reference's own row is over the range all its seeds cover."""
    groups = frontier_groups(runs)
    ranges: dict[tuple[str, str], tuple[float, float]] = {}
    out = []
    for env in sorted({e for e, _ in groups}):
        methods = method_order(m for e, m in groups if e == env)
        for m in methods:
            pair = [m] if m == reference or reference not in methods else [m, reference]
            lo, hi = common_range(groups, env, effort, pair)
            ranges[(env, m)] = (lo, hi)
            if not lo < hi:
                continue
            values = _seed_areas(groups[(env, m)], effort, outcome, lo, hi, points)
            vals = list(values.values())
            ci = bootstrap_ci(vals) if vals else (math.nan, math.nan)
            if len(pair) == 2:
                paired = _paired(_seed_areas(groups[(env, reference)], effort, outcome, lo, hi, points), values)
            else:
                paired = NO_PAIRS
            out.append(
                MatchedComparison(
                    env,
                    math.nan,
                    outcome,
                    m,
                    len(vals),
                    float(np.mean(vals)) if vals else math.nan,
                    ci,
                    reference,
                    *paired,
                    effort_range=(lo, hi),
                )
            )
    return ranges, out
