"""One process per run directory: a second process is refused with one clear line; the same process may
take the lock again; a killed holder leaves no stale lock."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from dpiil_rl.records.run_lock import RunDirInUse, hold_run_dir

HOLD = textwrap.dedent("""
    import sys, time
    from dpiil_rl.records.run_lock import hold_run_dir
    hold_run_dir(sys.argv[1]); print("held", flush=True); time.sleep(60)
""")


def test_a_second_process_is_refused_and_a_killed_holder_leaves_no_lock(tmp_path: Path) -> None:
    run = tmp_path / "run"
    holder = subprocess.Popen([sys.executable, "-c", HOLD, str(run)], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "held"
        with pytest.raises(RunDirInUse, match=rf"in use by pid {holder.pid}; expected one process per run"):
            hold_run_dir(run)
    finally:
        holder.kill()
        holder.wait()
    hold_run_dir(run)  # the killed holder's lock is gone with it
    hold_run_dir(run)  # and this process may take its own lock again


def test_a_second_training_of_the_same_run_stops_with_one_line(tmp_path: Path) -> None:
    run = tmp_path / "run"
    holder = subprocess.Popen([sys.executable, "-c", HOLD, str(run)], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "held"
        out = subprocess.run(
            [sys.executable, "-m", "dpiil_rl.cli.train", "experiment=smoke", f"hydra.run.dir={run}"],
            capture_output=True,
            text=True,
            cwd=tmp_path,
            timeout=300,
        )
    finally:
        holder.kill()
        holder.wait()
    assert out.returncode == 2, out.stderr
    assert out.stderr.strip().splitlines()[-1].startswith("error: run_dir = ")
    assert "in use by pid" in out.stderr and not (run / "episodes.jsonl").exists()
