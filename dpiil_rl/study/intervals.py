"""How sure a comparison is: bootstrap confidence intervals over seeds, the Welch interval of a difference,
and the number of seeds a standard power calculation asks for.

- :func:`bootstrap_ci`: percentile bootstrap of the mean over seeds (10,000 resamples, a fixed seed, so a
  report is reproducible); with one seed there is no interval.
- :func:`welch_interval`: the two-sided confidence interval of ``mean(a) − mean(b)`` with the
  Welch–Satterthwaite degrees of freedom (what the Welch t-test inverts).
- :func:`seeds_for_power`: seeds per method for a two-sided two-sample t-test at level ``alpha`` to detect
  the observed difference with probability ``power`` (Cohen's d with the pooled std; the exact power from
  the noncentral t distribution, as in G*Power or statsmodels' ``TTestIndPower``).
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np
from scipy import stats

RESAMPLES = 10_000
MAX_SEEDS = 100_000  # beyond this a difference is reported as not resolvable by seeds


def bootstrap_ci(
    values: Sequence[float] | np.ndarray, level: float = 0.95, resamples: int = RESAMPLES, seed: int = 0
) -> tuple[float, float]:
    """Percentile bootstrap interval of the mean of ``values``; ``(nan, nan)`` with fewer than 2 values."""
    a = np.asarray(values, dtype=float)
    if a.size < 2:
        return math.nan, math.nan
    rng = np.random.default_rng(seed)
    means = a[rng.integers(0, a.size, size=(resamples, a.size))].mean(axis=1)
    tail = (1.0 - level) / 2.0
    return float(np.quantile(means, tail)), float(np.quantile(means, 1.0 - tail))


def welch_interval(a: Sequence[float], b: Sequence[float], level: float = 0.95) -> tuple[float, float]:
    """Confidence interval of ``mean(a) − mean(b)`` (Welch); ``(nan, nan)`` with fewer than 2 values in a group.
    Both groups constant: the interval is the difference itself."""
    x, y = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if x.size < 2 or y.size < 2:
        return math.nan, math.nan
    diff = float(x.mean() - y.mean())
    vx, vy = x.var(ddof=1) / x.size, y.var(ddof=1) / y.size
    se = math.sqrt(vx + vy)
    if se == 0.0:
        return diff, diff
    df = (vx + vy) ** 2 / (vx**2 / (x.size - 1) + vy**2 / (y.size - 1))
    h = float(stats.t.ppf(0.5 + level / 2.0, df)) * se
    return diff - h, diff + h


def power(n: int, d: float, alpha: float = 0.05) -> float:
    """Power of the two-sided two-sample t-test with ``n`` per group at effect size ``d`` (Cohen's d)."""
    df = 2 * n - 2
    nc = abs(d) * math.sqrt(n / 2.0)
    crit = float(stats.t.ppf(1.0 - alpha / 2.0, df))
    return float(stats.nct.sf(crit, df, nc) + stats.nct.cdf(-crit, df, nc))


def cohens_d(a: Sequence[float], b: Sequence[float]) -> float:
    """``(mean(a) − mean(b)) / pooled std``; ±inf when both are constant and differ, nan when equal and constant."""
    x, y = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    pooled = math.sqrt(((x.size - 1) * x.var(ddof=1) + (y.size - 1) * y.var(ddof=1)) / (x.size + y.size - 2))
    diff = float(x.mean() - y.mean())
    if pooled == 0.0:
        return math.nan if diff == 0.0 else math.copysign(math.inf, diff)
    return diff / pooled


def seeds_for_power(a: Sequence[float], b: Sequence[float], alpha: float = 0.05, target: float = 0.8) -> float:
    """Seeds per method that resolve the observed difference of ``a`` and ``b`` (power ``target`` at
    ``alpha``): the smallest n ≥ 2 with enough power. nan with fewer than 2 seeds in a group or no
    difference at all; inf when not even :data:`MAX_SEEDS` would do; 2 for constant groups that differ."""
    if len(a) < 2 or len(b) < 2:
        return math.nan
    d = cohens_d(a, b)
    if math.isnan(d) or d == 0.0:
        return math.nan
    if math.isinf(d):
        return 2.0
    lo, hi = 2, 2
    while power(hi, d, alpha) < target:
        lo, hi = hi, hi * 2
        if hi > MAX_SEEDS:
            return math.inf
    while lo < hi:  # the smallest n with enough power
        mid = (lo + hi) // 2
        if power(mid, d, alpha) >= target:
            hi = mid
        else:
            lo = mid + 1
    return float(hi)


def paired_interval(differences: Sequence[float], level: float = 0.95) -> tuple[float, float]:
    """The t interval of the mean of paired ``differences``; ``(nan, nan)`` with fewer than 2."""
    d = np.asarray(differences, dtype=float)
    if d.size < 2:
        return math.nan, math.nan
    se = float(d.std(ddof=1)) / math.sqrt(d.size)
    if se == 0.0:
        return float(d.mean()), float(d.mean())
    h = float(stats.t.ppf(0.5 + level / 2.0, d.size - 1)) * se
    return float(d.mean()) - h, float(d.mean()) + h


def paired_power(n: int, dz: float, alpha: float = 0.05) -> float:
    """Power of the two-sided paired t-test with ``n`` pairs at effect size ``dz = mean / sd`` of the differences."""
    df = n - 1
    nc = abs(dz) * math.sqrt(n)
    crit = float(stats.t.ppf(1.0 - alpha / 2.0, df))
    return float(stats.nct.sf(crit, df, nc) + stats.nct.cdf(-crit, df, nc))


def seeds_for_power_paired(differences: Sequence[float], alpha: float = 0.05, target: float = 0.8) -> float:
    """Seeds (pairs) a paired t-test needs to resolve the observed mean difference with power ``target``;
    nan without a difference or with fewer than 2 pairs, 2 for a constant non-zero difference, inf beyond
    :data:`MAX_SEEDS`."""
    d = np.asarray(differences, dtype=float)
    if d.size < 2 or float(d.mean()) == 0.0:
        return math.nan
    sd = float(d.std(ddof=1))
    if sd == 0.0:
        return 2.0
    dz = float(d.mean()) / sd
    lo, hi = 2, 2
    while paired_power(hi, dz, alpha) < target:
        lo, hi = hi, hi * 2
        if hi > MAX_SEEDS:
            return math.inf
    while lo < hi:
        mid = (lo + hi) // 2
        if paired_power(mid, dz, alpha) >= target:
            hi = mid
        else:
            lo = mid + 1
    return float(hi)
