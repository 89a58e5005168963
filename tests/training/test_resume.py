"""A run killed with SIGKILL mid-way resumes from its last checkpoint, buffer and χ intact, and
ends exactly where an uninterrupted run with the same seed ends."""

import json
import os
import signal
import subprocess
import sys
import time

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
