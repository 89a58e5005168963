"""A tiny end-to-end run writes every contract file, and its numbers recompute from episodes.jsonl."""

import json
from pathlib import Path

import pytest
import torch

from dpiil_rl.records.run_files import read_jsonl
from dpiil_rl.training.evaluation import evaluate_run
from dpiil_rl.utils.code_version import code_version
from dpiil_rl.utils.machine import machine_facts
from tests.conftest import run_script, smoke_overrides


@pytest.fixture(scope="module")
def smoke_run(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("smoke") / "run"
    proc = run_script("train", *smoke_overrides(run_dir, *FINAL_TEST))
    return run_dir, proc


FINAL_TEST = ("logger=csv", "protocol.final_eval_episodes=6")  # the final test on 6 common starts


def test_writes_the_run_directory_contract(smoke_run):
    run_dir, proc = smoke_run
    for name in (
        ".hydra/config.yaml",
        "metrics.jsonl",
        "episodes.jsonl",
        "summary.json",
        "paths.jsonl",
        "checkpoints/latest",
        "checkpoints/iter_002/state.pt",
        "plots/learning_curve.png",
        "plots/maps_initial.png",
        "plots/maps_final.png",
    ):
        assert (run_dir / name).exists(), name
    assert list((run_dir / "csv").rglob("*.csv")), "CSV logger wrote nothing"
    assert "interactive success" in proc.stdout  # the one-screen summary


def test_metrics_rows_follow_the_contract(smoke_run):
    run_dir, _ = smoke_run
    metrics = read_jsonl(run_dir / "metrics.jsonl")
    assert [m["iteration"] for m in metrics] == [0, 1, 2]
    for m in metrics:
        for key in (
            "expert_actions",
            "interactive_success",
            "autonomous_success",
            "interventions",
            "collisions",
            "chi",
        ):
            assert key in m
    assert metrics[0]["interactive_success"] is None  # no interaction before iteration 1
    assert metrics[1]["expert_actions"] - metrics[0]["expert_actions"] >= 40  # the quota (episode finishes)
    assert all(m["eval_episodes"] == 20 for m in metrics)


def test_summary_recomputes_from_episodes(smoke_run):
    run_dir, _ = smoke_run
    rows = read_jsonl(run_dir / "episodes.jsonl")
    summary = json.loads((run_dir / "summary.json").read_text())
    inter = [r for r in rows if r["phase"] == "interactive"]
    final = [r for r in rows if r["phase"] == "eval" and r["iteration"] == 2]
    assert summary["interactive_success"] == pytest.approx(sum(r["success"] for r in inter) / len(inter))
    assert summary["autonomous_success"] == pytest.approx(sum(r["success"] for r in final) / len(final))
    assert summary["expert_actions"] == sum(r["expert_steps"] for r in rows if r["phase"] != "eval")
    assert summary["interventions"] == sum(r["interventions"] for r in inter)
    assert (summary["env"], summary["method"], summary["seed"]) == ("aperture", "dpiil_ucb", 0)
    assert summary["wall_time_s"] > 0
    assert summary["machine"] == machine_facts()  # what the records' bits depend on beyond the config
    assert summary["code"] == code_version()  # the package version and, from a checkout, its commit
    # the buffer in the last checkpoint holds exactly the expert-labelled pairs
    state = torch.load(run_dir / "checkpoints/iter_002/state.pt", weights_only=False)
    assert state["iteration"] == 2 and torch.isfinite(state["gate"]["chi"])
    metrics = read_jsonl(run_dir / "metrics.jsonl")
    assert metrics[-1]["dataset_size"] == summary["expert_actions"]


def test_rerun_of_a_finished_run_is_skipped(smoke_run):
    run_dir, _ = smoke_run
    before = (run_dir / "summary.json").read_text()
    proc = run_script("train", *smoke_overrides(run_dir, *FINAL_TEST))
    assert "already finished" in proc.stdout
    assert (run_dir / "summary.json").read_text() == before


def test_the_final_policy_is_tested_on_the_common_starts_inside_the_run(smoke_run):
    run_dir, proc = smoke_run
    name = "common_6ep_seed12345"
    saved = json.loads((run_dir / "evaluations" / f"{name}.json").read_text())
    rows = read_jsonl(run_dir / "evaluations" / name / "episodes.jsonl")
    assert saved["episodes"] == len(rows) == 6 and saved["checkpoint"] == "iter_002" and saved["seed"] == 12345
    assert saved["success"] == pytest.approx(sum(r["success"] for r in rows) / 6)
    assert f"final evaluation {name}" in proc.stdout
    # exactly what dpiil-evaluate writes afterwards, in another process
    run_script("evaluate", f"run_dir={run_dir}", "episodes=6", "num_envs=6", "name=standalone")
    assert read_jsonl(run_dir / "evaluations" / "standalone" / "episodes.jsonl") == rows
    # stopped during it (its episodes cut short): the next start of the finished run makes it again, the same
    lines = (run_dir / "evaluations" / name / "episodes.jsonl").read_text().splitlines(keepends=True)
    (run_dir / "evaluations" / name / "episodes.jsonl").write_text("".join(lines[:2]))
    again = run_script("train", *smoke_overrides(run_dir, *FINAL_TEST))
    assert "already finished" in again.stdout and f"final evaluation {name}" in again.stdout
    assert read_jsonl(run_dir / "evaluations" / name / "episodes.jsonl") == rows


def test_an_env_that_cannot_skip_start_states_is_not_evaluated_in_chunks(smoke_run):
    run_dir, _ = smoke_run
    with pytest.raises(ValueError, match="max_envs: the env 'aperture' cannot skip start states"):
        evaluate_run(run_dir, episodes=6, num_envs=6, seed=1, name="chunks", max_envs=3)


def test_evaluate_on_a_wider_aperture(smoke_run):
    run_dir, _ = smoke_run
    proc = run_script(
        "evaluate",
        f"run_dir={run_dir}",
        "episodes=30",
        "num_envs=30",
        "++env.barriers.second_wall.aperture_width=2.5",
        "name=wide",
    )
    result = json.loads((run_dir / "evaluations" / "wide.json").read_text())
    assert result["episodes"] == 30 and result["env_overrides"] == {
        "barriers": {"second_wall": {"aperture_width": 2.5}}
    }
    assert 0.0 <= result["success"] <= 1.0
    assert len(read_jsonl(run_dir / "evaluations" / "wide" / "episodes.jsonl")) == 30
    assert '"success"' in proc.stdout


def test_evaluate_a_study_on_common_start_states(smoke_run, tmp_path):
    run_dir, _ = smoke_run
    out = tmp_path / "table"
    proc = run_script("evaluate", f"runs={run_dir.parent}", "episodes=12", "num_envs=6", f"out={out}", "name=common")
    table = (out / "common.md").read_text()
    assert "| aperture | dpiil_ucb | 1 |" in table and "same 12 start states" in table
    (result,) = json.loads((out / "common.json").read_text())
    assert (
        result["episodes"] == 12 and result["method"] == "dpiil_ucb" and "stages" not in result
    )  # no stages on this task
    assert len(read_jsonl(run_dir / "evaluations" / "common" / "episodes.jsonl")) == 12
    assert "common.md" in proc.stdout

    # run again: the run already has this evaluation, so it is reused (same table), unless fresh=true
    stamp = (run_dir / "evaluations" / "common.json").stat().st_mtime_ns
    again = run_script("evaluate", f"runs={run_dir.parent}", "episodes=12", "num_envs=6", f"out={out}", "name=common")
    assert "1 of 1 runs already had this evaluation" in again.stdout
    assert (run_dir / "evaluations" / "common.json").stat().st_mtime_ns == stamp
    assert (out / "common.md").read_text() == table
    run_script(
        "evaluate", f"runs={run_dir.parent}", "episodes=12", "num_envs=6", f"out={out}", "name=common", "fresh=true"
    )
    assert (run_dir / "evaluations" / "common.json").stat().st_mtime_ns != stamp
    # other settings under the same name are not a match: evaluated anew
    other = run_script("evaluate", f"runs={run_dir.parent}", "episodes=8", "num_envs=4", f"out={out}", "name=common")
    assert "already had" not in other.stdout
    assert json.loads((run_dir / "evaluations" / "common.json").read_text())["episodes"] == 8


def test_the_gate_trace_reads_the_saved_gate_along_autonomous_episodes(smoke_run):
    from dpiil_rl.training.gate_trace import trace_gate

    run_dir, _ = smoke_run
    result = trace_gate(run_dir, episodes=3, seed=5)
    rows = read_jsonl(Path(result["path"]))
    assert len(rows) == 3 and result["chi"] > 0
    for row in rows:
        n = row["length"]
        assert all(len(row[k]) == n for k in ("action_var", "speed_mu", "speed_sigma", "risk", "speed"))
        # the smoke run's method is DPIIL_UCB: risk = σ²_θ / (μ_λ + σ_λ) at every step
        for var, mu, sigma, risk in zip(row["action_var"], row["speed_mu"], row["speed_sigma"], row["risk"]):
            assert risk == pytest.approx(var / (mu + sigma), rel=1e-5)
        assert row["speed"][1] >= 0.0 and row["speed"][0] != row["speed"][0]  # nan at the first step
