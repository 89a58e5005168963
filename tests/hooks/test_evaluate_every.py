"""protocol.eval_every: test episodes only at k = 0, n, 2n, ... and after the last iteration. The same run keeps
one checkpoint (checkpoint_keep=1): iteration 0, which its figures read, and the newest."""

import json

import pytest
from hydra import compose, initialize_config_dir

from dpiil_rl.records.run_files import read_jsonl
from dpiil_rl.training.factory import build_trainer
from tests.conftest import ROOT, run_script, smoke_overrides


def test_eval_every_skips_intermediate_evaluations(tmp_path):
    run_dir = tmp_path / "run"
    run_script(
        "train",
        *smoke_overrides(
            run_dir,
            "logger=none",
            "protocol.iterations=3",
            "protocol.eval_every=2",
            "protocol.eval_episodes=5",
            "protocol.eval_envs=5",
            "checkpoint_keep=1",
        ),
    )
    evaluated = sorted({e["iteration"] for e in read_jsonl(run_dir / "episodes.jsonl") if e["phase"] == "eval"})
    assert evaluated == [0, 2, 3]
    metrics = read_jsonl(run_dir / "metrics.jsonl")
    assert metrics[1]["autonomous_success"] is None and metrics[3]["autonomous_success"] is not None
    assert json.loads((run_dir / "summary.json").read_text())["autonomous_success"] == metrics[3]["autonomous_success"]
    assert (run_dir / "plots" / "learning_curve.png").exists()
    assert sorted(p.name for p in (run_dir / "checkpoints").glob("iter_*")) == ["iter_000", "iter_003"]
    assert (run_dir / "checkpoints" / "latest").read_text().strip() == "iter_003"


def test_bad_eval_every_is_named(tmp_path):
    with initialize_config_dir(config_dir=str(ROOT / "configs"), version_base=None):
        cfg = compose("config", overrides=["experiment=smoke", "logger=none", "protocol.eval_every=0"])
    with pytest.raises(ValueError, match="protocol.eval_every = 0"):
        build_trainer(cfg, tmp_path / "bad")
