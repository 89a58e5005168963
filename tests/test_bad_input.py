"""Bad input gets a clear error naming the value and what was expected."""

import pytest
from hydra import compose, initialize_config_dir

from dpiil_rl.training.evaluation import evaluate_run
from dpiil_rl.training.factory import build_trainer
from tests.conftest import ROOT, run_script, smoke_overrides


@pytest.mark.parametrize(
    "override,expected",
    [
        ("env=maze", "Could not find 'env/maze'"),
        ("env.barriers.second_wall.aperture_width=0.3", "aperture_width = 0.3: narrower than the agent"),
    ],
)
def test_train_rejects_bad_input_by_name(tmp_path, override, expected):
    """Through the command line: a message, not a stack dump."""
    proc = run_script("train", *smoke_overrides(tmp_path / "run", override), check=False)
    assert proc.returncode != 0
    assert expected in proc.stderr + proc.stdout
    assert "Traceback" not in proc.stderr


def test_unknown_method_lists_the_available_ones(tmp_path):
    proc = run_script("train", *smoke_overrides(tmp_path / "run", "method=dagger_typo"), check=False)
    assert "Could not find 'method/dagger_typo'" in proc.stderr
    assert "dpiil_ucb" in proc.stderr and "dpiil_mu" in proc.stderr


@pytest.mark.parametrize(
    "override,expected",
    [
        ("env.barriers.second_wall.aperture_width=-1.0", "aperture_width = -1.0: expected a positive width"),
        ("method.threshold.quantile=1.2", "quantile = 1.2: expected a number strictly between 0 and 1"),
        ("protocol.expert_pairs_per_iteration=0", "expert_pairs_per_iteration = 0"),
        ("modules.speed_head.ignore=[velocity]", "not in this env's state parts; expected names from"),
        ("modules.speed_head.ignore=[position]", "nothing of the state is left to read"),
    ],
)
def test_values_are_checked_when_the_run_is_built(tmp_path, override, expected):
    """The same checks, in this process (the command line prints exactly these messages, as above)."""
    with initialize_config_dir(config_dir=str(ROOT / "configs"), version_base=None):
        cfg = compose("config", overrides=["experiment=smoke", "logger=none", override])
    with pytest.raises(ValueError, match=expected.replace("(", r"\(")):
        build_trainer(cfg, tmp_path / "run")


def test_missing_run_dir_is_named(tmp_path):
    missing = tmp_path / "no_such_run"
    with pytest.raises(FileNotFoundError, match="no_such_run.*no such directory"):
        evaluate_run(missing)
    proc = run_script("evaluate", f"run_dir={missing}", check=False)
    assert proc.returncode != 0 and "no such directory" in proc.stderr
    with pytest.raises(ValueError, match="episodes = 0: expected a positive number"):
        evaluate_run(missing, episodes=0)  # checked before the run is looked for
    with pytest.raises(ValueError, match="num_envs = -1: expected a positive number"):
        evaluate_run(missing, num_envs=-1)


def test_evaluate_needs_one_run_or_a_study(tmp_path):
    proc = run_script("evaluate", check=False)
    assert proc.returncode != 0 and "run_dir = None, runs = None: expected exactly one of them" in proc.stderr
    proc = run_script("evaluate", f"runs={tmp_path}", "iteration=2", check=False)
    assert proc.returncode != 0 and "iteration = 2" in proc.stderr
