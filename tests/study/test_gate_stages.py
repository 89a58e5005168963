"""Where the gate handed control to the person: per-stage counts from ``paths.jsonl`` rows."""

from types import SimpleNamespace

import pytest

from dpiil_rl.study.gate_stages import count_gate_stages, gate_stage_counts, gate_stages_markdown, gate_stages_section

STAGES = ("reach", "grasped", "lifted", "threaded")


def path(phase, modes, stages=None):
    row = {"episode": 0, "phase": phase, "iteration": 1, "expert_mode": list(modes)}
    if stages is not None:
        row["stage"] = list(stages)
    return row


def run(method, paths, env="ring", staged_episodes=True):
    episodes = [{"phase": "eval", "iteration": 1, "stage": "reach", "stage_index": 0}] if staged_episodes else []
    return SimpleNamespace(
        env=env,
        method=method,
        episodes=episodes,
        recorded={"stages": list(STAGES)} if staged_episodes else {},
        paths=lambda: paths,
    )


def test_counts_steps_and_person_steps_per_stage_of_interactive_paths_only():
    rows = [
        path("interactive", [0, 1, 1, 0], [0, 1, 1, 2]),
        path("interactive", [1, 0], [0, 0]),
        path("demo", [1, 1, 1], [0, 1, 2]),
    ]
    steps, expert, n = count_gate_stages(rows, len(STAGES))
    assert n == 2 and dict(steps) == {0: 3, 1: 2, 2: 1} and dict(expert) == {0: 1, 1: 2, 2: 0}


def test_pools_seeds_per_method_and_leaves_out_unstaged_runs_and_methods_without_interactive_paths():
    runs = [
        run("dpiil_ucb", [path("interactive", [1, 1, 0], [1, 1, 0])]),
        run("dpiil_ucb", [path("interactive", [0, 1], [0, 1])]),
        run("ensemble_dagger", [path("interactive", [1, 0], None)]),  # recorded before per-step stages
        run("bc", [path("demo", [1, 1], [0, 1])]),
    ]
    counts = {c.method: c for c in gate_stage_counts(runs, len(STAGES))}
    assert set(counts) == {"dpiil_ucb", "ensemble_dagger"}  # BC has no interactive paths
    ucb = counts["dpiil_ucb"]
    assert (
        ucb.runs == 2
        and dict(ucb.steps) == {0: 2, 1: 3}
        and (ucb.expert[0], ucb.expert[1]) == (0, 3)
        and ucb.expert_steps == 3
    )
    assert counts["ensemble_dagger"].runs == 0 and counts["ensemble_dagger"].unstaged_runs == 1
    lines = gate_stages_markdown(list(counts.values()), STAGES, "ring")
    table = "\n".join(lines)
    assert "| ring | dpiil_ucb | 2 | 3 | 0% (0% of 2) | 100% (100% of 3) |" in table  # stages no step was in: no column
    assert "| env | method | runs | person's steps | reach | grasped |" in table
    assert "left out: ensemble_dagger (1)" in table


def test_no_staged_paths_says_so_and_an_env_without_stages_gives_no_section():
    lines = gate_stages_markdown(
        gate_stage_counts([run("hg_dagger", [path("interactive", [1], None)])], 4), STAGES, "ring"
    )
    assert "No run has per-step stages" in "\n".join(lines) and "hg_dagger (1)" in "\n".join(lines)
    assert (
        gate_stages_section([run("dpiil_ucb", [path("interactive", [1], [0])], env="aperture", staged_episodes=False)])
        == ""
    )
    assert "## Where the person was asked to act" in gate_stages_section(
        [run("dpiil_ucb", [path("interactive", [1], [0])])]
    )


def test_a_path_with_mismatched_or_unknown_stages_is_named():
    with pytest.raises(ValueError, match="2 stages for 3 steps"):
        count_gate_stages([path("interactive", [1, 0, 1], [0, 1])], len(STAGES))
    with pytest.raises(ValueError, match=r"stage 7 \(expected 0..3\)"):
        count_gate_stages([path("interactive", [1], [7])], len(STAGES))


def test_a_methods_variant_is_its_own_row_not_pooled_with_the_method():
    plain = run("dpiil_ucb", [path("interactive", [1, 0], [0, 1])])
    variant = run("dpiil_ucb", [path("interactive", [1, 1], [0, 1])])
    variant.run_name = "dpiil_ucb-no_velocity_precision"
    counts = {c.method: c for c in gate_stage_counts([plain, variant], len(STAGES))}
    assert counts["dpiil_ucb"].expert_steps == 1 and counts["dpiil_ucb-no_velocity_precision"].expert_steps == 2
