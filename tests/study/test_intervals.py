import math
from typing import Any, cast

import numpy as np
import pytest
from scipy import stats

from dpiil_rl.study.intervals import bootstrap_ci, power, seeds_for_power, welch_interval


def test_bootstrap_interval_covers_the_mean_and_is_reproducible():
    values = [0.9, 1.0, 0.95, 0.8, 1.0, 0.85]
    lo, hi = bootstrap_ci(values)
    assert lo < np.mean(values) < hi and 0.8 <= lo and hi <= 1.0
    assert bootstrap_ci(values) == (lo, hi)
    assert all(math.isnan(x) for x in bootstrap_ci([0.5]))


def test_welch_interval_is_what_the_welch_test_inverts():
    a, b = [0.9, 1.0, 0.95, 0.8, 1.0], [0.6, 0.7, 0.9, 0.5, 0.75, 0.8]
    lo, hi = welch_interval(a, b)
    p = cast(Any, stats.ttest_ind(a, b, equal_var=False)).pvalue  # scipy's result fields: unknown to the checker
    assert (lo > 0) == (p < 0.05)
    # at the level 1 − p the interval just touches 0
    lo_p, _ = welch_interval(a, b, level=1 - p)
    assert lo_p == pytest.approx(0.0, abs=1e-9)


def test_seeds_for_power_matches_the_textbook_numbers():
    # Cohen's d = 0.5 needs 64 per group, d = 0.8 needs 26 (two-sided, α = 0.05, power 0.8)
    assert power(64, 0.5) >= 0.8 > power(63, 0.5)
    rng = np.random.default_rng(0)
    a = rng.normal(0, 1, 1000)
    a = (a - a.mean()) / a.std(ddof=1)
    b = a + 0.8  # d = −0.8 exactly
    assert seeds_for_power(list(a), list(b)) == 26.0
    assert math.isnan(seeds_for_power([1.0, 1.0], [1.0, 1.0]))  # no difference to resolve
    assert seeds_for_power([1.0, 1.0], [0.5, 0.5]) == 2.0
