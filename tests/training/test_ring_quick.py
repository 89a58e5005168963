"""``env=ring experiment=ring_quick``: the whole loop on robosuite, every method's code path unchanged."""

import json

from dpiil_rl.envs.ring_task import RING_STAGES
from dpiil_rl.records.run_files import read_jsonl
from dpiil_rl.training.evaluation import evaluate_run
from tests.conftest import run_script


def test_ring_quick_run(tmp_path, method="dpiil_ucb"):
    # one method: the loop is method-agnostic; the ring expert's HG-DAgger rule is tested on its own
    run_dir = tmp_path / method
    proc = run_script(
        "train",
        "env=ring",
        "experiment=ring_quick",
        f"method={method}",
        f"hydra.run.dir={run_dir}",
        "logger=csv",
        timeout=900,
    )
    assert "interactive success" in proc.stdout
    summary = json.loads((run_dir / "summary.json").read_text())
    assert summary["env"] == "ring" and summary["method"] == method
    assert summary["stages"] == list(RING_STAGES)
    episodes = read_jsonl(run_dir / "episodes.jsonl")
    demos = [e for e in episodes if e["phase"] == "demo"]
    assert len(demos) == 2 and all(e["success"] for e in demos)  # the scripted expert threads the ring
    assert all("collision_steps" in e for e in episodes)
    assert all(e["stage"] in RING_STAGES for e in episodes)  # how far every episode got
    assert all(e["stage"] == "threaded" for e in demos)
    paths = read_jsonl(run_dir / "paths.jsonl")  # every step's stage, beside the gate's expert_mode
    assert paths and all(len(p["stage"]) == len(p["expert_mode"]) for p in paths)
    assert all(max(p["stage"]) == RING_STAGES.index("at_peg") for p in paths if p["phase"] == "demo")
    metrics = read_jsonl(run_dir / "metrics.jsonl")
    assert [m["iteration"] for m in metrics] == [0, 1]
    new_pairs = metrics[1]["expert_actions"] - metrics[0]["expert_actions"]
    assert new_pairs >= 60 or metrics[1]["episodes"] == 3  # the quota, or the episode cap when rarely asked
    assert (run_dir / "checkpoints" / "iter_001" / "state.pt").exists()
    assert (run_dir / "plots" / "learning_curve.png").exists()
    assert (run_dir / "plots" / "paths_demos.png").exists() and (
        run_dir / "plots" / "paths_interactive_final.png"
    ).exists()
    pairs = run_script("expert_pairs", f"runs={run_dir}", f"out={tmp_path / 'pairs.md'}")
    assert f"| {method} | 1 | demos (k = 0) |" in pairs.stdout and f"| {method} | 1 | k ≥ 1 |" in pairs.stdout
    assert (tmp_path / "pairs.md").read_text() in pairs.stdout and (tmp_path / "pairs.png").exists()
    report = run_script("report", f"runs={run_dir}", f"out={tmp_path / 'report'}")
    assert (tmp_path / "report" / "stages.png").exists(), report.stdout  # how far the episodes got, drawn
    results = (tmp_path / "report" / "results.md").read_text()
    assert "## How far the episodes got" in results and "## Where the person was asked to act" in results
    # the final test a few simulations at a time: the records of all its episodes side by side
    whole = evaluate_run(run_dir, episodes=4, num_envs=4, seed=7, name="whole")
    chunked = evaluate_run(run_dir, episodes=4, num_envs=4, seed=7, name="chunked", max_envs=2)
    assert (whole.pop("chunks"), chunked.pop("chunks")) == ([4], [2, 2])
    assert chunked == whole
    assert read_jsonl(run_dir / "evaluations/chunked/episodes.jsonl") == read_jsonl(
        run_dir / "evaluations/whole/episodes.jsonl"
    )
    again = run_script(
        "train",
        "env=ring",
        "experiment=ring_quick",
        f"method={method}",
        f"hydra.run.dir={run_dir}",
        "logger=csv",
        timeout=300,
    )
    assert "already finished" in again.stdout + again.stderr
