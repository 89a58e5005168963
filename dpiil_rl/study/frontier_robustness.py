"""Where the reference gate's advantage at matched effort holds: one verdict per (geometry, method).

The matched-effort comparisons of :mod:`dpiil_rl.study.frontier` are many tests (several effort levels and
the area under the frontier, on every geometry); read one by one at α = 0.05, some would come out
"significant" by chance. Here the tests of one method against the reference — interactive success at each
matched expert share and the area under the frontier (AUF), on every geometry of the study — form one
family, and their p-values are adjusted with Holm's step-down method (Holm 1979, *A simple sequentially
rejective multiple test procedure*: sort the m p-values, ``p_(i) ↦ max_{j ≤ i} min(1, (m − j + 1) p_(j))``),
which controls the family-wise error rate at α without assuming independence.

A geometry's verdict for a method:

- **holds**: some adjusted p < α with the reference better (Δ > 0), none with it worse;
- **reversed**: some adjusted p < α with the reference worse, none with it better;
- **mixed**: both;
- **not resolved**: no adjusted p < α; *at the ceiling* is added when both methods are at ≥ 99.5%
  interactive success at every compared level, so there is nothing left for a gate to win.

The seeds a paired t-test needs to resolve the observed AUF gap are given at the family's corrected level
(α / m, the first step of Holm), beside the uncorrected count.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from dpiil_rl.study.frontier import MatchedComparison
from dpiil_rl.study.intervals import seeds_for_power_paired

ALPHA = 0.05
CEILING = 0.995  # interactive success at or above this at every compared level: both gates at the ceiling


def holm(p_values: Sequence[float]) -> list[float]:
    """Holm's step-down adjusted p-values, in the order given (nan stays nan and is not counted in m)."""
    valid = [(p, i) for i, p in enumerate(p_values) if not math.isnan(p)]
    m = len(valid)
    out = [math.nan] * len(p_values)
    running = 0.0
    for rank, (p, i) in enumerate(sorted(valid)):
        running = max(running, min(1.0, (m - rank) * p))
        out[i] = running
    return out


@dataclass(frozen=True)
class Verdict:
    env: str
    method: str
    reference: str
    gaps: tuple[MatchedComparison, ...]  # the tested comparisons: the matched levels, then the AUF
    adjusted: tuple[float, ...]  # Holm-adjusted p of each, same order
    family: int  # m, the tests in the method's family (all geometries)
    seeds_auf: float  # seeds to resolve the AUF gap at α (uncorrected)
    seeds_auf_family: float  # ... at α / m
    at_ceiling: bool
    verdict: str


def verdicts(
    matched: Sequence[MatchedComparison],
    auf: Sequence[MatchedComparison],
    reference: str = "dpiil_ucb",
    outcome: str = "interactive_success",
    alpha: float = ALPHA,
) -> list[Verdict]:
    """One :class:`Verdict` per (geometry, method other than the reference), the family per method."""
    tested = [
        c
        for c in [*matched, *auf]
        if c.outcome == outcome and c.method != reference and c.reference == reference and not math.isnan(c.p_value)
    ]
    means = {(c.env, c.method, c.level): c.mean for c in [*matched, *auf] if c.outcome == outcome}
    out = []
    for method in sorted({c.method for c in tested}):
        family = [c for c in tested if c.method == method]
        adjusted = holm([c.p_value for c in family])
        m = len(family)
        for env in sorted({c.env for c in family}):
            rows = [(c, a) for c, a in zip(family, adjusted) if c.env == env]
            rows.sort(key=lambda r: (math.isnan(r[0].level), r[0].level))  # levels ascending, the AUF last
            better = any(a < alpha and c.diff > 0 for c, a in rows)
            worse = any(a < alpha and c.diff < 0 for c, a in rows)
            levels = [c.level for c, _ in rows if not math.isnan(c.level)]
            ceiling = bool(levels) and all(
                means.get((env, who, level), math.nan) >= CEILING for who in (method, reference) for level in levels
            )
            verdict = {
                (True, False): "holds",
                (False, True): "reversed",
                (True, True): "mixed",
            }.get((better, worse), "not resolved" + (" (both at the ceiling)" if ceiling else ""))
            auf_row = next((c for c, _ in rows if math.isnan(c.level)), None)
            diffs = auf_row.differences if auf_row is not None else ()
            out.append(
                Verdict(
                    env,
                    method,
                    reference,
                    tuple(c for c, _ in rows),
                    tuple(a for _, a in rows),
                    m,
                    seeds_for_power_paired(diffs, alpha) if len(diffs) >= 2 else math.nan,
                    seeds_for_power_paired(diffs, alpha / m) if len(diffs) >= 2 else math.nan,
                    ceiling,
                    verdict,
                )
            )
    return out


def min_adjusted(v: Verdict) -> float:
    """The smallest Holm-adjusted p of a verdict's tests (nan without tests)."""
    ps = [a for a in v.adjusted if not math.isnan(a)]
    return float(np.min(ps)) if ps else math.nan
