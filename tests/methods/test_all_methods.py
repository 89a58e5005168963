"""The same test set for every method plug-in found in configs/method/ (imitation-style)."""

from pathlib import Path

import pytest
from hydra import compose, initialize_config_dir

from dpiil_rl.methods.base import Method
from dpiil_rl.records.run_files import read_jsonl
from dpiil_rl.training.factory import build_trainer, make_method
from tests.conftest import ROOT

METHODS = sorted(p.stem for p in (ROOT / "configs" / "method").glob("*.yaml"))


def _cfg(method: str, seed: int, *extra: str):
    with initialize_config_dir(str(ROOT / "configs"), version_base="1.3"):
        return compose(
            "config",
            overrides=[
                f"method={method}",
                f"seed={seed}",
                "experiment=smoke",
                "protocol.iterations=1",
                "plots=false",
                *extra,
            ],
        )


def _run(method: str, seed: int, run_dir: Path) -> list[dict]:
    """One smoke run without its figures (half a smoke run's time; the plot hook has its own tests)."""
    trainer = build_trainer(_cfg(method, seed), run_dir)
    trainer.train()
    return read_jsonl(run_dir / "episodes.jsonl")


@pytest.mark.parametrize("method", METHODS)
def test_method_plugin_is_a_method_named_like_its_file(method):
    """A method's YAML names it; its class lives in ``dpiil_rl/methods/<module>.py`` with a test file
    ``tests/methods/test_<module>.py``. A variant (``dagger_1step``, ``thrifty_dagger_authors``) is a YAML
    of another method's class with other settings, named apart."""
    cfg = _cfg(method, 0).method
    m = make_method(cfg)
    assert isinstance(m, Method) and m.name == method
    package, module = str(cfg._target_).rsplit(".", 2)[:2]
    assert package == "dpiil_rl.methods"
    assert (ROOT / "dpiil_rl" / "methods" / f"{module}.py").exists()
    assert (ROOT / "tests" / "methods" / f"test_{module}.py").exists()
    if module != method:  # a variant: it says which settings differ
        assert (ROOT / "configs" / "method" / f"{module}.yaml").exists()


@pytest.mark.parametrize("method", METHODS)
def test_method_collects_its_quota_and_is_reproducible(method, tmp_path):
    a = _run(method, 0, tmp_path / "a")
    b = _run(method, 0, tmp_path / "b")
    assert a == b  # same seed, same episodes
    pairs = sum(r["expert_steps"] for r in a if r["phase"] != "eval" and r["iteration"] == 1)
    assert pairs >= 40  # the iteration's quota of expert pairs was reached
    c = _run(method, 1, tmp_path / "c")
    assert [r["start"] for r in c] != [r["start"] for r in a]
