"""A run killed with SIGKILL mid-way resumes from its last checkpoint, buffer and χ intact, and
ends exactly where an uninterrupted run with the same seed ends."""

import json
import os
import signal
import subprocess
import sys
import time
from typing import Any

import pytest
import torch

from dpiil_rl.records.run_files import read_jsonl
from tests.conftest import ROOT, run_script, smoke_overrides

# slower fits widen the window in which the kill lands between checkpoints
OVERRIDES = (
    "protocol.iterations=3",
    "modules.actor.fit.steps=400",
    "modules.actor.fit.epochs=null",
    "modules.speed_head.fit.steps=400",
)


def _ignore_time(summary):
    return {k: v for k, v in summary.items() if k != "wall_time_s"}


def test_kill_and_resume_matches_an_uninterrupted_run(tmp_path):
    reference = tmp_path / "reference"
    run_script("train", *smoke_overrides(reference, *OVERRIDES))

    killed = tmp_path / "killed"
    cmd = [sys.executable, "-m", "dpiil_rl.cli.train", *smoke_overrides(killed, *OVERRIDES)]
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    deadline = time.time() + 240
    while not (killed / "checkpoints" / "iter_001" / "state.pt").exists():
        assert proc.poll() is None, "the run ended before it could be killed"
        assert time.time() < deadline
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    assert not (killed / "summary.json").exists()
    state = torch.load(
        killed / "checkpoints" / (killed / "checkpoints" / "latest").read_text().strip() / "state.pt",
        weights_only=False,
    )
    resumed_from = state["iteration"]
    assert resumed_from < 3

    out = run_script("train", *smoke_overrides(killed, *OVERRIDES))
    assert "resuming" in out.stdout
    ref_summary = json.loads((reference / "summary.json").read_text())
    got_summary = json.loads((killed / "summary.json").read_text())
    assert _ignore_time(got_summary) == _ignore_time(ref_summary)
    assert read_jsonl(killed / "episodes.jsonl") == read_jsonl(reference / "episodes.jsonl")  # no duplicate rows
    ref_metrics = [
        {k: v for k, v in m.items() if not k.startswith("time/")} for m in read_jsonl(reference / "metrics.jsonl")
    ]
    got_metrics = [
        {k: v for k, v in m.items() if not k.startswith("time/")} for m in read_jsonl(killed / "metrics.jsonl")
    ]
    assert got_metrics == ref_metrics  # same χ, same dataset sizes, same successes


def _records(run_dir):
    metrics = [{k: v for k, v in m.items() if not k.startswith("time/")} for m in read_jsonl(run_dir / "metrics.jsonl")]
    return read_jsonl(run_dir / "episodes.jsonl"), read_jsonl(run_dir / "paths.jsonl"), metrics


@pytest.mark.parametrize("where", ["demos", "interaction", "refit"])
def test_a_paused_run_with_a_scripted_expert_ends_as_if_never_stopped(where, tmp_path):
    """Stopped inside the demos, inside an interactive round (2 robots side by side, so an episode is in
    progress) or inside a refit, the run continues to the records of a run that was never stopped."""
    from hydra import compose, initialize_config_dir

    from dpiil_rl.experts.base import SessionEnded
    from dpiil_rl.training.factory import build_trainer

    overrides = ["experiment=smoke", "logger=none", "plots=false", "protocol.demo_episodes=6"]
    overrides += ["protocol.interactive_envs=2", "protocol.iterations=1"]
    with initialize_config_dir(str(ROOT / "configs"), version_base="1.3"):
        cfg = compose("config", overrides=overrides)
    build_trainer(cfg, tmp_path / "reference").train()

    trainer = build_trainer(cfg, tmp_path / "run")
    if where == "refit":
        refit = trainer.hook("post_iteration", "refit")
        assert refit is not None

        def stop(trainer):
            refit(trainer)  # the refit's random draws are made, then Ctrl-C (SIGTERM pauses the same way)
            raise KeyboardInterrupt

        hooks: Any = trainer._hooks  # Any: the test swaps a plain function in
        hooks["post_iteration"] = [(n, stop if n == "refit" else h) for n, h in hooks["post_iteration"]]
    else:
        record, seen, stop_at = trainer.record_episode, [0], 3 if where == "demos" else 9

        def record_then_stop(episode):
            record(episode)
            seen[0] += 1
            if seen[0] == stop_at:
                raise SessionEnded("stopped")

        trainer.record_episode = record_then_stop  # type: ignore[method-assign]
    with pytest.raises((SessionEnded, KeyboardInterrupt)):
        trainer.train()
    assert not (tmp_path / "run" / "summary.json").exists()
    build_trainer(cfg, tmp_path / "run").train()
    assert _records(tmp_path / "run") == _records(tmp_path / "reference")
