"""How far episodes got: stage counts per method from ``episodes.jsonl`` rows."""

from types import SimpleNamespace

import pytest

from dpiil_rl.study.stage_table import episodes_of_kind, stage_counts, stage_order, stages_section

STAGES = ("reach", "grasped", "lifted", "threaded")


def row(phase, iteration, stage=None, success=False):
    r = {"phase": phase, "iteration": iteration, "success": success}
    if stage is not None:
        r.update(stage=stage, stage_index=STAGES.index(stage))
    return r


def run(method, rows, env="ring", staged=True):
    return SimpleNamespace(env=env, method=method, episodes=rows, recorded={"stages": list(STAGES)} if staged else {})


def test_counts_the_last_evaluation_per_stage_pooled_over_seeds():
    runs = [
        run("bc", [row("eval", 0, "reach"), row("eval", 5, "threaded", True), row("eval", 5, "lifted")]),
        run("bc", [row("eval", 5, "reach"), row("eval", 5, "threaded", True)]),
        run("dpiil_ucb", [row("interactive", 1, "grasped"), row("eval", 5, "grasped")]),
    ]
    counts = {c.method: c for c in stage_counts(runs, "final_eval")}
    assert counts["bc"].runs == 2 and counts["bc"].episodes == 4  # iteration 0's test episode is not the last
    assert dict(counts["bc"].counts) == {"threaded": 2, "lifted": 1, "reach": 1}
    assert dict(counts["dpiil_ucb"].counts) == {"grasped": 1}
    assert [c.method for c in stage_counts(runs)] == ["bc", "dpiil_ucb"]  # the paper's order
    inter = {c.method: c for c in stage_counts(runs, "interactive")}
    assert dict(inter["dpiil_ucb"].counts) == {"grasped": 1} and inter["bc"].episodes == 0
    assert inter["bc"].runs == inter["bc"].unstaged_runs == 0  # no interactive episodes: not "left out"


def test_order_comes_from_the_summary_else_from_the_recorded_index():
    rows = [row("eval", 0, s) for s in ("threaded", "reach", "lifted")]
    assert stage_order(rows, [run("bc", rows)]) == list(STAGES)  # every stage, reached or not
    assert stage_order(rows) == ["reach", "lifted", "threaded"]


def test_section_per_env_and_unstaged_runs_are_named():
    runs = [
        run("bc", [row("eval", 5, "reach"), row("eval", 5, "threaded", True)]),
        run("bc", [row("eval", 5)], staged=False),  # recorded before stages existed
        run("bc", [row("eval", 5)], env="aperture", staged=False),
    ]
    text = stages_section(runs)
    assert "### ring: autonomous test episodes of the last iteration" in text
    assert "| ring | bc | 1 | 2 | 50% (1) | 0% (0) | 0% (0) | 50% (1) |" in text
    assert "left out: bc (1)" in text
    assert "aperture" not in text  # no stages on that task: no table
    assert stages_section([run("bc", [row("eval", 5)], staged=False)]) == ""


def test_bad_kind_is_named():
    with pytest.raises(ValueError, match="kind = 'test'"):
        episodes_of_kind([], "test")


def test_a_methods_variant_is_its_own_row_not_pooled_with_the_method():
    plain = run("dpiil_ucb", [row("eval", 5, "threaded", True)])
    variant = run("dpiil_ucb", [row("eval", 5, "reach")])
    variant.run_name = "dpiil_ucb-no_velocity_precision"
    counts = {c.method: c for c in stage_counts([plain, variant])}
    assert set(counts) == {"dpiil_ucb", "dpiil_ucb-no_velocity_precision"}
    assert dict(counts["dpiil_ucb"].counts) == {"threaded": 1}
    assert dict(counts["dpiil_ucb-no_velocity_precision"].counts) == {"reach": 1}
