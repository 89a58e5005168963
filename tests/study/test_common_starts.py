"""The common-start study table: intervals, the Welch test against the reference, runs not evaluated."""

from typing import Any

import pytest
from scipy import stats

from dpiil_rl.study.common_starts import evaluate_study, study_evaluation_markdown
from tests.study.synthetic_runs import write_study


def _results(method, rates):
    return [{"env": "ring", "method": method, "seed": s, "success": x, "rows": []} for s, x in enumerate(rates)]


def test_the_table_compares_each_method_with_the_reference_by_welch():
    ref, other = [0.9, 0.95, 1.0, 0.85], [0.7, 0.8, 0.75, 0.6]
    text = study_evaluation_markdown(
        _results("dpiil_ucb", ref) + _results("ensemble_dagger", other), 100, 7, "t", skipped=["ring/bc/seed_0"]
    )
    row = next(line for line in text.splitlines() if line.startswith("| ring | ensemble_dagger |"))
    test: Any = stats.ttest_ind(ref, other, equal_var=False)  # scipy's result fields: unknown to the checker
    p = test.pvalue
    lo, hi = test.confidence_interval()
    assert f"| +21.3 pts [{100 * lo:+.1f}, {100 * hi:+.1f}] | {p:.2g} |" in row  # Δ = 92.5 − 71.25 points
    ref_row = next(line for line in text.splitlines() if line.startswith("| ring | dpiil_ucb |"))
    assert "| – | – | – |" in ref_row  # the reference has no difference with itself
    assert "Not evaluated, no checkpoint (records only): 1 runs: ring/bc/seed_0" in text


def test_a_study_of_records_only_says_it_has_nothing_to_evaluate(tmp_path):
    write_study(tmp_path / "results")
    with pytest.raises(FileNotFoundError, match="has a checkpoint to evaluate"):
        evaluate_study(tmp_path / "results" / "synthetic")
