"""Statistics of a study: per-method mean ± std over seeds, Welch t-tests against a reference method,
and the correlation between log10(χ) and success for the χ-sensitivity runs (paper Fig. 3(c), 3(d)).

All numbers come from :class:`~dpiil_rl.study.study_runs.StudyRun.summary`, i.e. recomputed from
``episodes.jsonl``. Calibrated-χ runs (``chi_fixed is None``) make the main table and tests; fixed-χ
runs make the sensitivity statistics only.

Conventions (documented in ``stats.md`` too):

- std is the sample std (ddof = 1); with one seed it is undefined and reported as NaN.
- A bootstrap 95% interval of each mean over seeds, the Welch 95% interval of each difference and the
  seeds per method a power calculation asks for (power 0.8, α = 0.05): :mod:`dpiil_rl.study.intervals`.
- Welch t-test (``scipy.stats.ttest_ind(equal_var=False)``), two-sided. When both groups have zero
  variance the test is undefined (t = 0/0 or ±∞): equal means are reported as p = 1 (no evidence of a
  difference), different means as p = 0 (the limit of the test as both variances shrink) — each with a
  note saying so. A group with fewer than 2 seeds gives p = NaN ("no test").
- r² is the squared Pearson correlation of the per-run points (log10 χ, success), every seed a point,
  not of the per-χ means. Constant input (e.g. every run 100%) gives r² = NaN with a note.
"""

from __future__ import annotations

import math
import warnings
from collections import defaultdict
from dataclasses import dataclass
from typing import Any, Iterable, Sequence, cast

import numpy as np
from scipy import stats

from dpiil_rl.study.intervals import bootstrap_ci, seeds_for_power, welch_interval
from dpiil_rl.study.study_runs import StudyRun, method_order

#: the per-run numbers of the results table: safety while learning (pooled and per iteration), the final
#: policy alone, and the person's effort (expert actions = labels in D, their share of the interactive
#: steps they drove, every step they had to act or judge, the hand-overs)
FIELDS = (
    "interactive_success",
    "interactive_success_iter_mean",
    "autonomous_success",
    "expert_actions",
    "expert_share",
    "expert_queries",
    "interventions",
    "collisions",
)
#: the numbers compared between methods (paper Fig. 3(c)) and correlated with χ (Fig. 3(d))
TESTED_FIELDS = ("interactive_success", "autonomous_success")
#: significance levels and their marks, strictest first
STAR_LEVELS = ((5e-4, "***"), (5e-3, "**"), (5e-2, "*"))


@dataclass(frozen=True)
class MeanStd:
    mean: float
    std: float  # sample std; NaN with a single value
    n: int
    ci_low: float = math.nan  # bootstrap 95% interval of the mean over seeds (NaN with a single value)
    ci_high: float = math.nan


@dataclass
class MethodStats:
    """Mean ± std over seeds of each field for one (env, method); ``None`` where no run has the field."""

    env: str
    method: str
    seeds: list[int]
    values: dict[str, MeanStd | None]


@dataclass(frozen=True)
class WelchTest:
    env: str
    field: str
    reference: str
    method: str
    n_reference: int
    n_method: int
    mean_reference: float
    mean_method: float
    statistic: float
    p_value: float
    note: str = ""
    diff_low: float = math.nan  # Welch 95% interval of mean_reference − mean_method
    diff_high: float = math.nan
    seeds_needed: float = math.nan  # seeds per method for power 0.8 at α = 0.05 on the observed difference


@dataclass(frozen=True)
class ChiFit:
    env: str
    method: str
    field: str
    n: int
    r: float
    r_squared: float
    p_value: float
    note: str = ""


@dataclass(frozen=True)
class ChiPoint:
    """Mean ± std over seeds of the tested fields at one fixed χ."""

    env: str
    method: str
    chi: float
    seeds: list[int]
    values: dict[str, MeanStd | None]


def main_runs(runs: Iterable[StudyRun]) -> list[StudyRun]:
    """Runs with the calibrated χ (the comparison between methods)."""
    return [r for r in runs if r.chi_fixed is None]


def sensitivity_runs(runs: Iterable[StudyRun]) -> list[StudyRun]:
    """Runs with a fixed χ (the sensitivity study)."""
    return [r for r in runs if r.chi_fixed is not None]


def by_env_method(runs: Iterable[StudyRun], by_run_name: bool = False) -> dict[str, dict[str, list[StudyRun]]]:
    """``{env: {method: runs sorted by seed}}``, envs sorted, methods in the paper's order. ``by_run_name``
    groups by the runs' names instead (a frontier study: one group per method and knob value)."""
    groups: dict[str, dict[str, list[StudyRun]]] = defaultdict(lambda: defaultdict(list))
    for run in runs:
        groups[run.env][run.run_name if by_run_name else run.method].append(run)
    return {
        env: {m: sorted(methods[m], key=lambda r: (r.seed, r.chi_fixed or 0.0)) for m in method_order(methods)}
        for env, methods in sorted(groups.items())
    }


def values_of(runs: Iterable[StudyRun], field: str) -> list[float]:
    """The field's recomputed value of every run that has one (e.g. BC has no interactive success)."""
    return [float(r.summary[field]) for r in runs if r.summary.get(field) is not None]


def mean_std(values: Sequence[float]) -> MeanStd | None:
    if not values:
        return None
    a = np.asarray(values, dtype=float)
    lo, hi = bootstrap_ci(a)
    return MeanStd(float(a.mean()), float(a.std(ddof=1)) if len(a) > 1 else math.nan, len(a), lo, hi)


def method_stats(runs: Iterable[StudyRun]) -> list[MethodStats]:
    """Mean ± std of :data:`FIELDS` per (env, method) over the given runs (pass :func:`main_runs`)."""
    rows = []
    for env, methods in by_env_method(runs, by_run_name=True).items():
        for method, group in methods.items():
            rows.append(
                MethodStats(env, method, [r.seed for r in group], {f: mean_std(values_of(group, f)) for f in FIELDS})
            )
    return rows


def welch(a: Sequence[float], b: Sequence[float]) -> tuple[float, float, str]:
    """Two-sided Welch t-test of ``a`` vs ``b``: ``(t, p, note)`` with the zero-variance conventions above."""
    x, y = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if len(x) < 2 or len(y) < 2:
        return math.nan, math.nan, "fewer than 2 seeds in a group: no test"
    if x.var(ddof=1) == 0 and y.var(ddof=1) == 0:
        if x.mean() == y.mean():
            return 0.0, 1.0, "both groups constant and equal: t-test undefined, p = 1 (no difference)"
        t = math.copysign(math.inf, x.mean() - y.mean())
        return t, 0.0, "both groups constant with different means: t-test undefined, p = 0 is its limit"
    with warnings.catch_warnings():  # one constant group: scipy warns of precision loss, the test is still exact
        if x.var(ddof=1) == 0 or y.var(ddof=1) == 0:
            warnings.simplefilter("ignore", RuntimeWarning)
        result = cast(Any, stats.ttest_ind(x, y, equal_var=False))  # scipy's result fields: unknown to the checker
    return float(result.statistic), float(result.pvalue), ""


def welch_tests(
    runs: Iterable[StudyRun], reference: str = "dpiil_ucb", fields: Sequence[str] = TESTED_FIELDS
) -> list[WelchTest]:
    """The reference method against every other method of its env, on each field (pass :func:`main_runs`)."""
    tests = []
    for env, methods in by_env_method(runs, by_run_name=True).items():
        if reference not in methods:
            continue
        for field in fields:
            ref = values_of(methods[reference], field)
            for method, group in methods.items():
                other = values_of(group, field)
                if method == reference or not ref or not other:
                    continue
                t, p, note = welch(ref, other)
                lo, hi = welch_interval(ref, other)
                tests.append(
                    WelchTest(
                        env,
                        field,
                        reference,
                        method,
                        len(ref),
                        len(other),
                        float(np.mean(ref)),
                        float(np.mean(other)),
                        t,
                        p,
                        note,
                        lo,
                        hi,
                        seeds_for_power(ref, other),
                    )
                )
    return tests


def pearson_r2(x: Sequence[float], y: Sequence[float]) -> tuple[float, float, float, str]:
    """``(r, r², p, note)`` of the Pearson correlation; NaN with a note when it is undefined."""
    if len(x) < 2:
        return math.nan, math.nan, math.nan, "fewer than 2 runs: no correlation"
    if np.ptp(x) == 0 or np.ptp(y) == 0:
        return math.nan, math.nan, math.nan, "constant input: correlation undefined"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = cast(Any, stats.pearsonr(x, y))  # scipy's result fields: unknown to the checker
    r = float(result.statistic)
    return r, r * r, float(result.pvalue), ""


def chi_correlations(runs: Iterable[StudyRun], fields: Sequence[str] = TESTED_FIELDS) -> list[ChiFit]:
    """r² between log10(χ) and each field, per (env, method), over the fixed-χ runs (every seed a point)."""
    fits = []
    for env, methods in by_env_method(sensitivity_runs(runs)).items():
        for method, group in methods.items():
            for field in fields:
                points = [
                    (math.log10(float(r.chi_fixed)), float(r.summary[field]))  # type: ignore[arg-type]
                    for r in group
                    if r.summary.get(field) is not None
                ]
                x, y = [p[0] for p in points], [p[1] for p in points]
                r, r2, p, note = pearson_r2(x, y)
                fits.append(ChiFit(env, method, field, len(points), r, r2, p, note))
    return fits


def chi_points(runs: Iterable[StudyRun], fields: Sequence[str] = TESTED_FIELDS) -> list[ChiPoint]:
    """Mean ± std over seeds of each field at every fixed χ, per (env, method), χ ascending."""
    points = []
    for env, methods in by_env_method(sensitivity_runs(runs)).items():
        for method, group in methods.items():
            per_chi: dict[float, list[StudyRun]] = defaultdict(list)
            for run in group:
                per_chi[float(run.chi_fixed)].append(run)  # type: ignore[arg-type]
            for chi in sorted(per_chi):
                at = per_chi[chi]
                points.append(
                    ChiPoint(
                        env, method, chi, sorted(r.seed for r in at), {f: mean_std(values_of(at, f)) for f in fields}
                    )
                )
    return points


def significance_stars(p: float) -> str:
    """``***`` p < 5e-4, ``**`` p < 5e-3, ``*`` p < 5e-2, ``n.s.`` otherwise, ``n/a`` for NaN."""
    if p is None or math.isnan(p):
        return "n/a"
    for level, mark in STAR_LEVELS:
        if p < level:
            return mark
    return "n.s."
