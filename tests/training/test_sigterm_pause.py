"""SIGTERM (a batch system stopping the job, the end of a session) pauses a run inside an iteration:
its finished episodes are saved as ``checkpoints/pause`` and the same command finishes the run."""

import json
import os
import signal
import subprocess
import sys
import time

from dpiil_rl.records.run_files import read_jsonl
from tests.conftest import ROOT, run_script, smoke_overrides

# one long interactive iteration, so the signal lands inside it
OVERRIDES = (
    "protocol.iterations=1",
    "protocol.expert_pairs_per_iteration=600",
    "protocol.max_episodes_per_iteration=400",
)


def test_sigterm_pauses_inside_an_iteration_and_the_same_command_finishes(tmp_path):
    run_dir = tmp_path / "run"
    cmd = [sys.executable, "-m", "dpiil_rl.cli.train", *smoke_overrides(run_dir, *OVERRIDES)]
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout is not None  # piped
    deadline = time.time() + 240
    while not any(r["phase"] == "interactive" for r in read_jsonl(run_dir / "episodes.jsonl")):
        assert proc.poll() is None, f"the run ended before the signal:\n{proc.stdout.read()[-2000:]}"
        assert time.time() < deadline
        time.sleep(0.05)
    os.kill(proc.pid, signal.SIGTERM)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 128 + signal.SIGTERM, err[-2000:]  # the shell's convention: a sweep stops too
    assert "session paused (stopped by SIGTERM)" in out
    assert "leaked semaphore" not in err  # the process's locks are released before its hard exit
    assert (run_dir / "checkpoints" / "pause" / "state.pt").exists() and not (run_dir / "summary.json").exists()
    before = read_jsonl(run_dir / "episodes.jsonl")
    kept = [e for e in before if e["phase"] == "interactive"]
    assert kept and sum(e["expert_steps"] for e in kept) < 600  # stopped inside the iteration

    second = run_script("train", *smoke_overrides(run_dir, *OVERRIDES))
    assert "resuming" in second.stdout
    after = read_jsonl(run_dir / "episodes.jsonl")
    assert after[: len(before)] == before  # nothing collected before the signal is lost or redone
    assert [e["episode"] for e in after] == list(range(len(after)))
    pairs = sum(e["expert_steps"] for e in after if e["phase"] == "interactive")
    assert pairs >= 600  # one quota across the pause
    summary = json.loads((run_dir / "summary.json").read_text())
    assert summary["expert_actions"] == sum(e["expert_steps"] for e in after if e["phase"] != "eval")
    assert not (run_dir / "checkpoints" / "pause").exists()


def test_sigterm_to_a_study_pauses_every_run_in_progress_and_starts_no_other(tmp_path):
    """``make paper`` stopped with ``kill -TERM -<pgid>``: the runs in the joblib workers save their pause
    checkpoints, their processes end, and the sweep does not go on to its next run."""
    args = [
        sys.executable,
        "-m",
        "dpiil_rl.cli.train",
        "-m",
        "experiment=smoke",
        "seed=0,1,2",
        "study=s",
        f"run_root={tmp_path}",
        "hydra/launcher=joblib",
        "hydra.launcher.n_jobs=2",
        *OVERRIDES,
    ]
    proc = subprocess.Popen(
        args, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True
    )
    assert proc.stderr is not None  # piped
    runs = [tmp_path / "s" / "aperture" / "dpiil_ucb" / f"seed_{s}" for s in range(3)]
    deadline = time.time() + 300
    while not all(any(r["phase"] == "interactive" for r in read_jsonl(run / "episodes.jsonl")) for run in runs[:2]):
        assert proc.poll() is None, f"the study ended before the signal:\n{proc.stderr.read()[-2000:]}"
        assert time.time() < deadline
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGTERM)
    proc.communicate(timeout=120)
    assert proc.returncode != 0
    for run in runs[:2]:
        assert (run / "checkpoints" / "pause" / "state.pt").exists() and not (run / "summary.json").exists()
    assert not (runs[2] / "episodes.jsonl").exists()  # the sweep stopped: the third run never started
    # (continuing a paused run with the same command is the test above)
