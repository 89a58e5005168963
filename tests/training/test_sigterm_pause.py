"""SIGTERM (a batch system stopping the job, the end of a session) pauses a run inside an iteration and the
same command finishes it."""

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


def _without_time(rows):
    return [{k: v for k, v in r.items() if not k.startswith("time/")} for r in rows]


def test_sigterm_pauses_inside_an_iteration_and_the_same_command_finishes_as_if_never_stopped(tmp_path):
    """A scripted expert: the pause keeps every finished iteration and the run, continued, redoes the iteration
    it was stopped in, so its records are byte for byte those of a run that was never stopped (a person's
    finished episodes are kept instead: tests/training/test_mouse_session.py)."""
    reference = tmp_path / "reference"
    run_script("train", *smoke_overrides(reference, *OVERRIDES))
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
    assert "session paused (stopped by SIGTERM): the iteration in progress is redone" in out
    assert "leaked semaphore" not in err  # the process's locks are released before its hard exit
    assert not (run_dir / "summary.json").exists() and not (run_dir / "checkpoints" / "pause").exists()
    assert (run_dir / "checkpoints" / "latest").read_text().strip() == "iter_000"  # iteration 0 is kept

    second = run_script("train", *smoke_overrides(run_dir, *OVERRIDES))
    assert "resuming" in second.stdout
    assert (run_dir / "episodes.jsonl").read_text() == (reference / "episodes.jsonl").read_text()
    assert (run_dir / "paths.jsonl").read_text() == (reference / "paths.jsonl").read_text()
    assert _without_time(read_jsonl(run_dir / "metrics.jsonl")) == _without_time(
        read_jsonl(reference / "metrics.jsonl")
    )
    summary = {k: v for k, v in json.loads((run_dir / "summary.json").read_text()).items() if k != "wall_time_s"}
    assert summary == {
        k: v for k, v in json.loads((reference / "summary.json").read_text()).items() if k != "wall_time_s"
    }


def test_sigterm_to_a_study_pauses_every_run_in_progress_and_starts_no_other(tmp_path):
    """``make paper`` stopped with ``kill -TERM -<pgid>``: the runs in the joblib workers pause (their finished
    iterations kept), their processes end, and the sweep does not go on to its next run."""
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
        assert (run / "checkpoints" / "latest").exists() and not (run / "summary.json").exists()
    assert not (runs[2] / "episodes.jsonl").exists()  # the sweep stopped: the third run never started
    # (continuing a paused run with the same command is the test above)
