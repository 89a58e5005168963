"""Nothing is lost under faults: every method killed (SIGKILL) at seeded random points of its writes — a row
half-appended, a checkpoint's state half-saved, a buffer dumped but not renamed — resumes to the very
episodes.jsonl and summary.json of an uninterrupted run; a full disk stops a run with one line and it resumes
once there is space; a read-only run_root, a checkpoint of another method and a NaN from an env or an expert
each give one clear line.

``DPIIL_FAULTS=<n>`` (``make faults``) injects n kills per method instead of one; with ``DPIIL_FAULTS_REPORT=<file>``
each method appends its counts to that file.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import zlib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import torch
from hydra import compose, initialize_config_dir

from dpiil_rl.collectors.intervention import NonFiniteValue
from dpiil_rl.collectors.stop_rules import EpisodeBudget
from dpiil_rl.hooks.evaluate import autonomous_policy
from dpiil_rl.records.run_files import read_jsonl
from dpiil_rl.training.factory import build_trainer
from tests.conftest import ROOT

METHODS = sorted(p.stem for p in (ROOT / "configs" / "method").glob("*.yaml"))
FAULTS = int(os.environ.get("DPIIL_FAULTS", "1"))
UNWRITABLE = os.path.join(os.sep, "proc", "dpiil_rl_runs")  # a run_root no process may create
SETTINGS = ("experiment=smoke", "logger=none", "plots=false", "protocol.iterations=2")


def _child(*args: str, spec: dict | None = None) -> subprocess.CompletedProcess:
    env = {**os.environ, "HYDRA_FULL_ERROR": "0"}
    cmd = (
        [sys.executable, "-m", "tests.mocks.fault_injector", json.dumps(spec)]
        if spec
        else [sys.executable, "-m", "dpiil_rl.cli.train"]
    )
    return subprocess.run([*cmd, *args], cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)


def _summary(run: Path) -> dict:
    return {k: v for k, v in json.loads((run / "summary.json").read_text()).items() if k != "wall_time_s"}


def _sites(run: Path, buffers: int) -> int:
    """How many instrumented writes a run makes: appended rows, then per checkpoint a state, its buffers and
    two renames."""
    rows = sum(len(read_jsonl(run / name)) for name in ("episodes.jsonl", "metrics.jsonl", "paths.jsonl"))
    checkpoints = len(list((run / "checkpoints").glob("iter_*")))
    return rows + checkpoints * (1 + buffers + 2)


@pytest.mark.parametrize("method", METHODS)
def test_killed_anywhere_a_run_resumes_to_the_uninterrupted_records(method, tmp_path):
    overrides = (f"method={method}", "seed=5", *SETTINGS)
    with initialize_config_dir(str(ROOT / "configs"), version_base="1.3"):
        cfg = compose("config", overrides=list(overrides))
    reference = tmp_path / "reference"
    trainer = build_trainer(cfg, reference)
    trainer.train()
    total = _sites(reference, len(trainer.buffers()))
    rng = np.random.default_rng(zlib.crc32(method.encode()))
    points = sorted(int(n) for n in rng.choice(np.arange(1, total + 1), size=min(FAULTS, total), replace=False))
    identical = 0
    for n in points:
        run = tmp_path / f"killed_{n}"
        killed = _child(f"hydra.run.dir={run}", *overrides, spec={"fault": "kill", "n": n})
        assert killed.returncode == -9, (n, killed.stderr[-2000:])  # SIGKILL at write n
        resumed = _child(f"hydra.run.dir={run}", *overrides)
        assert resumed.returncode == 0, (n, resumed.stderr[-2000:])
        assert (run / "episodes.jsonl").read_text() == (reference / "episodes.jsonl").read_text(), n
        assert _summary(run) == _summary(reference), n
        identical += 1
    line = (
        f"faults: {method}: {len(points)} kills injected of {total} write points, {identical} runs recovered identical"
    )
    print(line)
    if os.environ.get("DPIIL_FAULTS_REPORT"):  # make faults collects the counts of every method
        with open(os.environ["DPIIL_FAULTS_REPORT"], "a") as f:
            f.write(line + "\n")


def test_a_full_disk_stops_with_one_line_and_the_run_resumes_once_there_is_space(tmp_path):
    overrides = ("method=dpiil_ucb", "seed=2", *SETTINGS)
    reference, run = tmp_path / "reference", tmp_path / "full"
    assert _child(f"hydra.run.dir={reference}", *overrides).returncode == 0
    full = _child(f"hydra.run.dir={run}", *overrides, spec={"fault": "enospc", "n": 40})
    assert full.returncode == 2
    assert full.stderr.strip().splitlines()[-1].startswith("error: no space left on the device")
    assert "Traceback" not in full.stderr
    again = _child(f"hydra.run.dir={run}", *overrides)
    assert again.returncode == 0 and "resuming" in again.stdout
    assert (run / "episodes.jsonl").read_text() == (reference / "episodes.jsonl").read_text()
    assert _summary(run) == _summary(reference)


@pytest.mark.parametrize(
    "root, message",
    [
        ("", "run_root = '': expected a directory"),
        (UNWRITABLE, f"run_root = '{UNWRITABLE}': cannot write there"),
    ],
)
def test_an_unwritable_or_missing_run_root_is_one_line(root, message):
    proc = _child(f"run_root={root}", *SETTINGS)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1 and lines[0].startswith(f"error: {message}"), proc.stderr


def test_a_checkpoint_of_another_method_is_refused_and_kept(tmp_path):
    run = tmp_path / "run"
    _child(f"hydra.run.dir={run}", "method=dagger", *SETTINGS, spec={"fault": "kill", "n": 60})
    before = sorted(p.name for p in (run / "checkpoints").iterdir())
    proc = _child(f"hydra.run.dir={run}", "method=ensemble_dagger", *SETTINGS)
    assert proc.returncode == 2
    assert "its checkpoint was made by env aperture, method dagger" in proc.stderr and "overwrite=true" in proc.stderr
    assert sorted(p.name for p in (run / "checkpoints").iterdir()) == before  # nothing was touched


def test_a_nan_from_the_expert_or_the_env_names_the_value_and_keeps_what_was_recorded(tmp_path):
    with initialize_config_dir(str(ROOT / "configs"), version_base="1.3"):
        cfg = compose("config", overrides=["method=bc", *SETTINGS])
    trainer = build_trainer(cfg, tmp_path / "run")
    expert: Any = trainer.collector.expert  # Any: the test patches its get_action
    original = expert.get_action
    calls = {"n": 0}

    def glitch(td):
        calls["n"] += 1
        action = original(td)
        return action * float("nan") if calls["n"] == 150 else action  # a device glitch in iteration 1's demos

    expert.get_action = glitch
    with pytest.raises(NonFiniteValue, match=r"the executed action .* is \[nan, nan\]: expected finite numbers"):
        trainer.train()
    rows = read_jsonl(tmp_path / "run" / "episodes.jsonl")
    assert [(r["phase"], r["iteration"]) for r in rows] == [("demo", 0)] + [("eval", 0)] * 20  # all recorded, kept
    # the same command continues from iteration 0's checkpoint (a scripted expert's iteration 1 is redone)
    assert (tmp_path / "run" / "checkpoints" / "latest").read_text().strip() == "iter_000"
    base: Any = trainer.collector.env.base_env  # Any: the test patches the task env's _step
    step = base._step

    def broken(td):
        out = step(td)
        out.set("observation", torch.full_like(out.get("observation"), float("inf")))
        return out

    base._step = broken
    with pytest.raises(NonFiniteValue, match=r"the env's next observation .* is \[inf, inf\]"):
        list(trainer.collector.rollout(EpisodeBudget(1), "eval", 0, policy=autonomous_policy(trainer.actor)))
