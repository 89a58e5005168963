"""Study statistics: mean ± sample std, Welch t-tests against scipy, zero-variance conventions, χ r²."""

import math
from typing import Any, cast

import numpy as np
import pytest
from scipy import stats

from dpiil_rl.study.study_runs import load_study
from dpiil_rl.study.study_stats import (
    MeanStd,
    chi_correlations,
    chi_points,
    main_runs,
    mean_std,
    method_stats,
    pearson_r2,
    significance_stars,
    welch,
    welch_tests,
)
from tests.study.synthetic_runs import write_chi_study, write_run, write_study


def present(value: MeanStd | None) -> MeanStd:
    """A field's statistic where the runs have the field (None where none has it)."""
    assert value is not None
    return value


@pytest.fixture
def study(tmp_path):
    write_study(tmp_path / "main")
    write_chi_study(tmp_path / "chi")
    return load_study([tmp_path / "main", tmp_path / "chi"])


def test_mean_and_sample_std_per_method(study):
    rows = {s.method: s for s in method_stats(main_runs(study))}
    assert list(rows) == ["bc", "dagger", "dpiil_ucb", "my_new_method"]  # paper order, unknown last
    runs = [r for r in study if r.method == "dagger"]
    inter = [r.summary["interactive_success"] for r in runs]
    assert present(rows["dagger"].values["interactive_success"]).mean == pytest.approx(np.mean(inter))
    assert present(rows["dagger"].values["interactive_success"]).std == pytest.approx(np.std(inter, ddof=1))
    assert present(rows["dagger"].values["expert_actions"]).mean == pytest.approx(3 * 80 + 2 * 10 * 20)
    assert rows["bc"].values["interactive_success"] is None  # BC has no interactive episodes
    assert present(rows["bc"].values["autonomous_success"]).mean == pytest.approx(np.mean([0.3, 0.25, 0.35]))
    assert rows["dagger"].seeds == [0, 1, 2]
    assert math.isnan(present(mean_std([0.5])).std) and mean_std([]) is None


@pytest.mark.filterwarnings("ignore:Precision loss")  # scipy itself, on a constant group of the comparison
def test_welch_tests_match_scipy(study):
    tests = welch_tests(main_runs(study), reference="dpiil_ucb")
    by = {(t.method, t.field): t for t in tests}
    assert ("bc", "interactive_success") not in by  # nothing to compare
    assert ("dpiil_ucb", "interactive_success") not in by  # not against itself
    assert {m for m, _ in by} == {"bc", "dagger", "my_new_method"}
    for (method, field), t in by.items():
        ref = [r.summary[field] for r in study if r.method == "dpiil_ucb" and r.chi_fixed is None]
        other = [r.summary[field] for r in study if r.method == method and r.chi_fixed is None]
        # scipy builds its result types at import time: to the checker their fields are unknown (cast to Any)
        expected = cast(Any, stats.ttest_ind(ref, other, equal_var=False))
        assert t.p_value == pytest.approx(expected.pvalue) and t.statistic == pytest.approx(expected.statistic)
        assert (t.n_reference, t.n_method) == (len(ref), len(other)) and not t.note
    assert by[("dagger", "interactive_success")].p_value < 0.05  # 0.95 vs 0.52: clearly different


@pytest.mark.filterwarnings("ignore:Precision loss")
def test_welch_zero_variance_conventions():
    t, p, note = welch([1.0, 1.0, 1.0], [1.0, 1.0])
    assert (t, p) == (0.0, 1.0) and "equal" in note
    t, p, note = welch([1.0, 1.0], [0.5, 0.5])
    assert t == math.inf and p == 0.0 and "limit" in note
    t, p, note = welch([1.0, 1.0, 1.0], [0.5, 0.7, 0.9])  # one group constant: Welch is defined
    assert (
        p == pytest.approx(cast(Any, stats.ttest_ind([1.0, 1.0, 1.0], [0.5, 0.7, 0.9], equal_var=False)).pvalue)
        and not note
    )
    t, p, note = welch([1.0], [0.5, 0.6])
    assert math.isnan(p) and "fewer than 2" in note


def test_no_reference_runs_means_no_tests(study):
    assert welch_tests([r for r in main_runs(study) if r.method != "dpiil_ucb"]) == []


def test_r_squared_on_an_exactly_linear_example(tmp_path):
    write_chi_study(tmp_path, seeds=1)  # dpiil_ucb interactive 0.9, 0.7, 0.5 at log10 χ = -5, -4, -3
    fits = {(f.method, f.field): f for f in chi_correlations(load_study(tmp_path))}
    linear = fits[("dpiil_ucb", "interactive_success")]
    assert linear.r_squared == pytest.approx(1.0) and linear.r == pytest.approx(-1.0) and linear.n == 3
    constant = fits[("ensemble_dagger", "interactive_success")]  # 0.8 at every χ
    assert math.isnan(constant.r_squared) and "constant" in constant.note


def test_r_squared_matches_scipy_over_every_seed(study):
    fits = {(f.method, f.field): f for f in chi_correlations(study)}
    for (method, field), fit in fits.items():
        runs = [r for r in study if r.method == method and r.chi_fixed is not None]
        x = [math.log10(r.chi_fixed) for r in runs]
        y = [r.summary[field] for r in runs]
        assert fit.n == len(runs) == 6
        if np.ptp(y) > 0:
            assert fit.r_squared == pytest.approx(cast(Any, stats.pearsonr(x, y)).statistic ** 2)
    assert 0.5 < fits[("dpiil_ucb", "interactive_success")].r_squared < 1.0  # a trend with seed noise


def test_chi_points_average_the_seeds_per_chi(study):
    points = [p for p in chi_points(study) if p.method == "dpiil_ucb"]
    assert [p.chi for p in points] == pytest.approx([1e-5, 1e-4, 1e-3])
    assert all(p.seeds == [0, 1] for p in points)
    runs = [r for r in study if r.method == "dpiil_ucb" and r.chi_fixed == 1e-4]
    assert present(points[1].values["autonomous_success"]).mean == pytest.approx(
        np.mean([r.summary["autonomous_success"] for r in runs])
    )


def test_pearson_with_too_few_points():
    assert math.isnan(pearson_r2([1.0], [2.0])[1])


@pytest.mark.parametrize(
    "p,mark",
    [
        (1e-4, "***"),
        (4.9e-4, "***"),
        (5e-4, "**"),
        (4e-3, "**"),
        (0.01, "*"),
        (0.049, "*"),
        (0.05, "n.s."),
        (0.5, "n.s."),
        (math.nan, "n/a"),
    ],
)
def test_significance_stars(p, mark):
    assert significance_stars(p) == mark


def test_sensitivity_runs_stay_out_of_the_main_table(tmp_path):
    write_run(tmp_path, "dpiil_ucb", 0, [1.0], [1.0, 1.0])
    write_run(tmp_path, "dpiil_ucb", 0, [0.0], [0.0, 0.0], chi_fixed=1e-5)
    rows = method_stats(main_runs(load_study(tmp_path)))
    assert len(rows) == 1 and present(rows[0].values["interactive_success"]).mean == 1.0
