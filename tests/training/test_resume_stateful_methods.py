"""Methods with state beyond the policy (DAgger's random stream, ThriftyDAgger's critic and its
experience buffer, LazyDAgger's classifier, τ, β_R and noise stream) resume from a checkpoint exactly where an
uninterrupted run would be."""

from pathlib import Path

import pytest
from hydra import compose, initialize_config_dir

from dpiil_rl.hooks.base import LoopHook
from dpiil_rl.records.run_files import read_jsonl
from dpiil_rl.training.factory import build_trainer
from tests.conftest import ROOT


class Crash(LoopHook):
    """Dies after the checkpoint of iteration ``at`` (as a killed process would)."""

    def __init__(self, at: int) -> None:
        self.at = at

    def __call__(self, trainer):
        if trainer.iteration == self.at:
            raise KeyboardInterrupt("simulated crash")
        return {}


def _cfg(method: str):
    name, *extra = method.split(" ")
    with initialize_config_dir(str(ROOT / "configs"), version_base="1.3"):
        return compose(
            "config", overrides=[f"method={name}", "seed=3", "experiment=smoke", "protocol.iterations=2", *extra]
        )


def _strip(rows):
    return [{k: v for k, v in r.items() if not k.startswith("time/")} for r in rows]


@pytest.mark.parametrize("method", ["dagger", "thrifty_dagger", "lazy_dagger method.supervisor_noise=0.2"])
def test_crash_and_resume_matches_uninterrupted(method, tmp_path: Path):
    build_trainer(_cfg(method), tmp_path / "ref").train()

    run = tmp_path / "crashed"
    trainer = build_trainer(_cfg(method), run)
    Crash(1).register(trainer, "crash")
    with pytest.raises(KeyboardInterrupt):
        trainer.train()
    assert (run / "checkpoints" / "iter_001" / "state.pt").exists()
    if method == "thrifty_dagger":
        assert (run / "checkpoints" / "iter_001" / "experience").is_dir()

    resumed = build_trainer(_cfg(method), run)
    assert resumed.iteration == 1
    resumed.train()
    assert read_jsonl(run / "episodes.jsonl") == read_jsonl(tmp_path / "ref" / "episodes.jsonl")
    assert _strip(read_jsonl(run / "metrics.jsonl")) == _strip(read_jsonl(tmp_path / "ref" / "metrics.jsonl"))
