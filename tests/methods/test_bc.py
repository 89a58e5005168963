from hydra import compose, initialize_config_dir

from dpiil_rl.methods.bc import BC
from dpiil_rl.records.run_files import read_jsonl
from dpiil_rl.training.factory import build_trainer
from tests.conftest import ROOT


def test_bc_never_hands_control_to_the_robot_during_training(tmp_path):
    with initialize_config_dir(str(ROOT / "configs"), version_base="1.3"):
        cfg = compose("config", overrides=["method=bc", "experiment=smoke", "protocol.iterations=2"])
    build_trainer(cfg, tmp_path).train()
    rows = read_jsonl(tmp_path / "episodes.jsonl")
    training = [r for r in rows if r["phase"] != "eval"]
    assert {r["phase"] for r in training} == {"demo"}
    assert all(r["expert_steps"] == r["length"] for r in training)  # whole expert demonstrations
    for k in (1, 2):  # each iteration adds demonstrations until its quota of expert pairs is met
        assert sum(r["expert_steps"] for r in training if r["iteration"] == k) >= 40
    summary = read_jsonl(tmp_path / "metrics.jsonl")[-1]
    assert summary["interactive_success"] is None and summary["autonomous_success"] is not None


def test_bc_is_not_interactive():
    assert BC("bc").interactive is False
