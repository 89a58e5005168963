"""Ring safety from a run's records: failures and contacts by stage, the gate's risk / χ, the robot's speed where
the gate handed over, how failed episodes ended; and the tables over seeds."""

from __future__ import annotations

import json
import math
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from dpiil_rl.records.metrics import run_summary
from dpiil_rl.study.intervals import bootstrap_ci, welch_interval
from dpiil_rl.study.ring_safety import (
    ALL,
    WINDOW,
    MethodSafety,
    final_auto_steps,
    handover_curve,
    method_safety,
    run_safety,
    spearman,
)
from dpiil_rl.study.ring_safety_report import (
    cell,
    failed_episode_section,
    gap_section,
    handover_by_speed_section,
    headline_section,
    interval,
    ring_safety_markdown,
    risk_section,
    speed_section,
)
from tests.conftest import run_script

STAGES = ["reach", "grasped", "lifted", "at_peg", "threaded"]


def episode(n: int, phase: str, k: int, success: bool, stage: str, contact_steps: int = 0) -> dict[str, Any]:
    return {
        "episode": n,
        "phase": phase,
        "iteration": k,
        "success": success,
        "collision": contact_steps > 0,
        "collision_steps": contact_steps,
        "stage": stage,
        "stage_index": STAGES.index(stage),
    }


def path(n: int, k: int, xs: list[float], modes: list[bool], risk: list[float], stage: list[int] | None) -> dict:
    row = {
        "episode": n,
        "phase": "interactive",
        "iteration": k,
        "positions": [[x, 0.0, 1.0] for x in xs],
        "expert_mode": modes,
        "risk": risk,
    }
    if stage is not None:
        row["stage"] = stage
    return row


def the_run(method: str = "dpiil_ucb", seed: int = 0, staged: bool = True, flip: bool = False) -> SimpleNamespace:
    """Three interactive episodes under χ = 2 (iteration 1) and χ = 4 (iteration 2); ``flip`` makes one step
    disagree with risk > χ (a gate with memory)."""
    episodes = [
        episode(0, "demo", 0, True, "threaded"),
        episode(1, "interactive", 1, True, "threaded", contact_steps=3),
        episode(2, "interactive", 1, False, "at_peg"),
        episode(3, "interactive", 2, False, "lifted", contact_steps=2),
    ]
    n2 = WINDOW + 2
    paths = [
        # x in metres: incoming speeds (cm/step) at t = 1, 2, 3 are 1.2, 2, 0
        path(1, 1, [0.0, 0.012, 0.032, 0.032, 0.044], [False, True, False, False], [1.0, 3.0, 1.0, 0.5], [0, 0, 1, 1]),
        # the expert drives the first step only; then the robot moves 1.2 cm/step to the end, risk / χ = 0.5
        path(2, 1, [0.012 * t for t in range(n2 + 1)], [True] + [False] * (n2 - 1), [3.0] + [1.0] * (n2 - 1), [3] * n2),
        path(3, 2, [0.0] * 4, [True, True, flip], [5.0, 6.0, 1.0], [2, 2, 1]),
    ]
    if not staged:
        paths = [{k: v for k, v in p.items() if k != "stage"} for p in paths]
    return SimpleNamespace(
        method=method,
        seed=seed,
        episodes=episodes,
        metrics=[{"iteration": 0, "chi": 2.0}, {"iteration": 1, "chi": 4.0}, {"iteration": 2, "chi": 8.0}],
        summary={"interactive_success": 1 / 3},
        recorded={"stages": STAGES},
        paths=lambda: paths,
    )


def test_failures_and_contacts_count_by_the_furthest_stage_of_interactive_episodes():
    s = run_safety(the_run(), "new")
    assert s.episodes == 3 and s.success == pytest.approx(1 / 3)
    assert dict(s.failures) == {"at_peg": 1, "lifted": 1}
    assert dict(s.contacts) == {"threaded": 1, "lifted": 1}
    assert dict(s.contact_steps) == {"threaded": 3, "lifted": 2}


def test_steps_and_expert_steps_per_stage_of_the_state():
    s = run_safety(the_run(), "new")
    assert s.staged and s.stage_keys() == [ALL, 0, 1, 2, 3, 4]
    assert s.steps[ALL] == 4 + WINDOW + 2 + 3 and s.expert[ALL] == 1 + 1 + 2
    assert (s.steps[0], s.expert[0]) == (2, 1)
    assert (s.steps[1], s.expert[1]) == (3, 0)
    assert (s.steps[2], s.expert[2]) == (2, 2)
    assert (s.steps[3], s.expert[3]) == (WINDOW + 2, 1)


def test_a_threshold_gate_has_its_risk_over_the_chi_of_the_refit_before_the_iteration():
    s = run_safety(the_run(), "new")
    assert s.gate_agreement == 1.0 and s.threshold_gate
    assert sorted(s.risk_ratio[2]) == [1.25, 1.5]  # iteration 2 reads χ = 4 (metrics row of iteration 1)
    assert sorted(s.risk_ratio[1]) == [0.25, 0.25, 0.5]
    assert len(s.risk_ratio[ALL]) == s.steps[ALL]


def test_a_gate_that_is_not_risk_over_chi_gets_no_risk_ratio():
    s = run_safety(the_run(flip=True), "new")
    assert s.gate_agreement == pytest.approx((s.steps[ALL] - 1) / s.steps[ALL])
    assert not s.threshold_gate and s.risk_ratio == {}
    assert all(math.isnan(f.final_risk_ratio) for f in s.failed)


def test_a_gate_without_a_recorded_chi_or_risk_is_not_a_threshold_gate():
    run = the_run(method="dagger")
    run.metrics = [{"iteration": k, "chi": None} for k in range(3)]
    s = run_safety(run, "old")
    assert math.isnan(s.gate_agreement) and not s.threshold_gate and s.risk_ratio == {}


def test_the_robots_own_speed_into_the_state_at_steps_the_robot_drove_before():
    s = run_safety(the_run(), "new")
    # episode 1: t = 1 (robot drove t = 0; 1.2 cm/step; handed over), t = 3 (robot drove t = 2; still; kept driving);
    # t = 2 is left out: the expert drove t = 1
    assert s.speed[0] == pytest.approx([1.2]) and s.handed_over[0] == [True] and s.risk[0] == [3.0]
    assert s.speed[1][:1] == pytest.approx([0.0]) and s.handed_over[1][:1] == [False]
    # episode 3: t = 2 follows an expert step; t = 0 has no step before it: nothing of stage 1 or 2 from it
    assert len(s.speed[1]) == 1 and s.speed[2] == []
    # episode 2: the robot drove t = 1 .. n - 2 before steps 2 .. n - 1, at 1.2 cm/step, never handing over
    assert s.speed[3] == pytest.approx([1.2] * WINDOW) and not any(s.handed_over[3])
    assert len(s.speed[ALL]) == 2 + WINDOW


def test_how_each_failed_episode_ended():
    s = run_safety(the_run(), "new")
    at_peg, lifted = sorted(s.failed, key=lambda f: f.stage)
    assert at_peg.stage == "at_peg" and at_peg.last_stage == "at_peg"
    assert at_peg.final_auto == WINDOW + 1 and at_peg.expert_share == pytest.approx(1 / (WINDOW + 2))
    assert at_peg.final_speed == pytest.approx(1.2) and at_peg.final_risk_ratio == pytest.approx(0.5)
    assert lifted.last_stage == "grasped" and lifted.final_auto == 1
    assert math.isnan(lifted.final_speed) and math.isnan(lifted.final_risk_ratio)  # fewer than WINDOW steps alone


def test_final_auto_steps():
    assert final_auto_steps([True, False, False]) == 2
    assert final_auto_steps([False, True]) == 0
    assert final_auto_steps([False, False]) == 2


def test_runs_without_per_step_stages_count_in_all_steps_only():
    s = run_safety(the_run(staged=False), "old")
    assert not s.staged and s.stage_keys() == [ALL]
    assert set(s.steps) == {ALL} and set(s.speed) == {ALL}
    assert all(f.last_stage is None for f in s.failed)
    group = method_safety([s, run_safety(the_run(seed=1), "old")])[0]
    assert len(group.runs_for(ALL)) == 2 and len(group.runs_for(3)) == 1


def test_a_path_whose_lengths_disagree_is_an_error():
    run = the_run()
    rows = run.paths()
    rows[0]["risk"] = rows[0]["risk"][:-1]
    with pytest.raises(ValueError, match="expected T, T, T and T \\+ 1"):
        run_safety(run, "new")


def test_per_seed_values_of_a_method():
    a = run_safety(the_run(seed=0), "new")
    b = run_safety(the_run(seed=1), "new")
    b.failures["at_peg"] += 2  # 3 of 3 episodes
    (group,) = method_safety([b, a])
    assert [r.seed for r in group.runs] == [0, 1]
    assert group.failure_rate("at_peg") == pytest.approx([100 / 3, 100.0])
    assert group.contact_rate("threaded") == pytest.approx([100 / 3, 100 / 3])
    assert group.expert_share(2) == [1.0, 1.0]
    assert group.handover_rate(0) == [1.0, 1.0] and group.handover_rate(3) == [0.0, 0.0]
    assert (
        group.speed_median(0, True) == pytest.approx([1.2, 1.2]) and group.speed_median(0, False) == []
    )  # nan left out


def test_spearman_is_the_rank_correlation_of_finite_pairs():
    assert spearman([1, 2, 3, math.nan], [3, 2, 1, 0]) == pytest.approx(-1.0)
    assert spearman([0.1, 0.5, 0.2, 0.9], [1, 8, 2, 30]) == pytest.approx(1.0)
    assert math.isnan(spearman([1, 1, 1], [1, 2, 3])) and math.isnan(spearman([1, 2], [2, 1]))


def test_handover_curve_pools_seeds_per_speed_bin():
    groups = method_safety([run_safety(the_run(seed=s), "new") for s in (0, 1)])
    curve = handover_curve(groups[0], ALL, bins=(0.0, 0.5, 1.5, math.inf))
    # robot-driven steps per seed: speed 1.2 handed over, speed 0 kept driving, WINDOW at 1.2 cm/step kept driving
    assert curve[0] == (0.0, 0.0, 2)
    assert curve[1][0] == 0.5 and curve[1][1] == pytest.approx(2 / (2 + 2 * WINDOW)) and curve[1][2] == 2 + 2 * WINDOW
    assert math.isnan(curve[2][1]) and curve[2][2] == 0


def test_cells_and_intervals():
    assert cell([]) == "–"
    assert cell([0.5], scale=100.0) == "50.0 (1 seed)"
    low, high = bootstrap_ci([1.0, 2.0, 3.0])
    assert cell([1.0, 2.0, 3.0]) == f"2.0 [{low:.1f}, {high:.1f}]"
    assert interval([1.0], [0.0, 2.0]) == "+0.0 (no CI: 1 and 2 seeds)"
    low, high = welch_interval([1.0, 2.0, 4.0], [0.0, 1.0])
    assert interval([1.0, 2.0, 4.0], [0.0, 1.0], digits=2) == f"+1.83 [{low:+.2f}, {high:+.2f}]"


def _groups() -> list[MethodSafety]:
    runs = [run_safety(the_run("dpiil_ucb", s), "new") for s in (0, 1)]
    runs += [run_safety(the_run("ensemble_dagger", 0), "new")]
    runs += [run_safety(the_run("dpiil_ucb", s, staged=False), "old") for s in (0, 1)]
    return method_safety(runs)


def test_tables_name_what_they_computed():
    groups = _groups()
    assert [(g.study, g.method) for g in groups] == [
        ("new", "ensemble_dagger"),
        ("new", "dpiil_ucb"),
        ("old", "dpiil_ucb"),
    ]
    head = "\n".join(headline_section(groups))
    # 2 of 3 episodes failed, 2 of 3 had a contact, 5 contact steps, 4 of 29 steps in expert mode
    share = f"{100 * 4 / (7 + WINDOW + 2):.1f}"
    row = "| new | dpiil_ucb | 2 | 6 (4 failed) | 33.3 [33.3, 33.3] | 66.7 [66.7, 66.7] | 66.7 [66.7, 66.7] |"
    row += " 5.0 [5.0, 5.0] |"
    assert f"{row} {share} [{share}, {share}] | yes |" in head
    assert "| new | ensemble_dagger | 1 | 3 (2 failed) | 33.3 (1 seed) |" in head
    gaps = "\n".join(gap_section(groups, "ensemble_dagger"))
    assert "| new | dpiil_ucb | ensemble_dagger | +0.0 (no CI: 2 and 1 seeds) |" in gaps
    assert "### Against the same method in new" in gaps and "| dpiil_ucb | old | new | +0.0 [+0.0, +0.0] |" in gaps
    failed = "\n".join(failed_episode_section(groups))
    # per study: 2 failed episodes per seed; one left alone for the last WINDOW steps, moving at 1.2 cm/step, risk/χ 0.5
    assert "| new | dpiil_ucb | all | 4 |" in failed and "| 2 | 0 / 0 / 2 (0.50) | grasped 2, at_peg 2 |" in failed
    assert "| old | dpiil_ucb | at_peg | 2 |" in failed and "| 2 | 0 / 0 / 2 (0.50) | – |" in failed
    risk = "\n".join(risk_section(groups))
    assert "| old | dpiil_ucb |" in risk and "(14% > 1) | – | – | – | – |" in risk  # 4 of 29 steps above χ
    speed = "\n".join(speed_section(groups))
    assert "| new | dpiil_ucb | reach | 2 of 2 | 100.0 [100.0, 100.0] | 1.20 [1.20, 1.20] | – | – |" in speed
    assert "| old | dpiil_ucb | reach |" not in speed  # no per-step stages in the old runs
    by_speed = "\n".join(handover_by_speed_section(groups))
    # per seed: one robot-driven step still (kept driving), one at 1.2 cm/step (handed over), WINDOW at 1.2 cm/step
    assert (
        f"| new | dpiil_ucb | 2 | 0.0% (2) | – | – | – | {100 * 2 / (2 + 2 * WINDOW):.1f}% ({2 + 2 * WINDOW}) |"
        in by_speed
    )
    text = ring_safety_markdown(groups, "ensemble_dagger", "dpiil-ring-safety out=x.md")
    assert "Made by `dpiil-ring-safety out=x.md`" in text and "old/dpiil_ucb (2)" in text


def test_the_figure_is_a_png(tmp_path):
    from dpiil_rl.study.ring_safety_figure import handover_figure
    from tests.study.test_study_report import assert_real_png

    out = handover_figure(_groups(), tmp_path / "handover.png", min_steps=1)
    assert_real_png(out)
    with pytest.raises(ValueError, match="no method with interactive episodes"):
        handover_figure([], tmp_path / "none.png")


def test_quantiles_of_risk_over_chi_are_computed_from_the_pooled_steps():
    groups = [g for g in _groups() if g.study == "new" and g.method == "dpiil_ucb"]
    ratio = groups[0].pooled("risk_ratio", ALL)
    assert ratio.size == 2 * (7 + WINDOW + 2)
    q = " / ".join(f"{v:.2g}" for v in np.quantile(ratio, (0.1, 0.5, 0.9, 0.99)))
    assert q in "\n".join(risk_section(groups))


def write_run_dir(root: Path, method: str, seed: int, staged: bool = True) -> Path:
    """:func:`the_run` as a finished run directory (its summary recomputes from its episodes)."""
    run = the_run(method, seed, staged)
    run_dir = root / method / f"seed_{seed}"
    (run_dir / ".hydra").mkdir(parents=True)
    (run_dir / ".hydra" / "config.yaml").write_text(f"env:\n  name: ring\nmethod:\n  name: {method}\nseed: {seed}\n")
    episodes = [
        {**e, "length": 4, "expert_steps": 1, "interventions": 1, "timeout": not e["success"]} for e in run.episodes
    ]
    summary = run_summary(episodes)
    recorded = {"env": "ring", "method": method, "seed": seed, "run_name": method, "stages": STAGES}
    recorded["interactive_success"] = summary["interactive_success"]
    (run_dir / "summary.json").write_text(json.dumps(recorded))
    for name, rows in (("episodes", episodes), ("metrics", run.metrics), ("paths", run.paths())):
        (run_dir / f"{name}.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    return run_dir


def test_the_command_reads_studies_and_writes_the_tables_and_the_figure(tmp_path):
    for seed in (0, 1):
        write_run_dir(tmp_path / "old", "dpiil_ucb", seed, staged=False)
        write_run_dir(tmp_path / "new", "dpiil_ucb", seed)
    write_run_dir(tmp_path / "new", "ensemble_dagger", 0)
    out = tmp_path / "report" / "ring_safety.md"
    studies = f"studies=[{{label:old,runs:'{tmp_path / 'old'}'}},{{label:new,runs:'{tmp_path / 'new'}'}}]"
    proc = run_script("ring_safety", studies, f"out={out}", "figure_methods=[dpiil_ucb]")
    text = out.read_text()
    assert (
        "| old | dpiil_ucb | 2 | 6 (4 failed) | 33.3 [33.3, 33.3] |" in text and "| new | ensemble_dagger | 1 |" in text
    )
    assert "| dpiil_ucb | new | old | +0.0 [+0.0, +0.0] |" in text
    assert out.with_suffix(".png").exists() and "wrote" in proc.stdout
    bad = run_script("ring_safety", f"studies=[{{label:x,runs:'{tmp_path / 'none'}'}}]", check=False)
    assert bad.returncode == 2 and "no such directory" in bad.stderr
