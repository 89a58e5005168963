import pytest
import torch
from tensordict import TensorDict

from dpiil_rl.envs.factory import make_env
from dpiil_rl.methods.safe_dagger import DiscrepancyGate, SafeDAgger
from dpiil_rl.modules.discrepancy_classifier import DiscrepancyClassifier
from dpiil_rl.modules.fitting import FitSettings
from dpiil_rl.modules.threshold import FixedThreshold, QuantileThreshold

LOW, HIGH = torch.tensor([-1.0, -1.0]), torch.tensor([1.0, 1.0])
CLASSIFIER = {
    "hidden": [32, 32],
    "balanced": True,
    "heldout_fraction": 0.3,
    "fit": {"steps": 600, "batch_size": 128, "lr": 3e-3},
}


def _gate(act_low=LOW, act_high=HIGH, hidden=(32, 32)) -> DiscrepancyGate:
    torch.manual_seed(0)
    return DiscrepancyGate(
        DiscrepancyClassifier(LOW, HIGH, hidden), act_low, act_high, QuantileThreshold(0.8), QuantileThreshold(0.8)
    )


def test_classifier_learns_where_the_policy_departs_from_the_expert_and_the_gate_asks_there():
    # the expert commands 0 everywhere; the policy agrees on the left and drifts off it for x > 0.5
    g = torch.Generator().manual_seed(0)
    obs = torch.rand(4000, 2, generator=g) * 2 - 1
    policy = torch.cat([(obs[:, :1] - 0.5).clamp_min(0) * 2, torch.zeros(4000, 1)], -1)
    expert = torch.zeros(4000, 2)
    gate = _gate()
    out = gate.fit_classifier(obs, policy, expert, FitSettings(steps=600, batch_size=128, lr=3e-3), g)
    assert abs(out["safe/unsafe_fraction"] - 0.2) < 0.01  # τ flags the 20% of D that departs most
    assert out["safe/classifier_accuracy"] > 0.95
    td = TensorDict({"observation": obs}, batch_size=[4000])
    assert abs(gate.calibrate(td)["train/flagged_fraction"] - 0.2) < 0.01
    probe = TensorDict({"observation": torch.tensor([[0.95, 0.0], [-0.5, 0.3], [0.0, -0.9]])}, batch_size=[3])
    assert gate(probe)["expert_mode"].reshape(-1).tolist() == [True, False, False]


def test_discrepancy_is_measured_in_action_spec_units():
    gate = _gate(act_low=torch.tensor([-2.0, -0.5]), act_high=torch.tensor([2.0, 0.5]))
    d = gate.discrepancy(torch.tensor([[1.0, 0.25]]), torch.tensor([[0.0, 0.0]]))
    assert torch.allclose(d, torch.tensor([[0.25 + 0.25]]))  # (1/2)² + (0.25/0.5)²


def test_gate_state_with_classifier_tau_and_chi_round_trips():
    gate = _gate()
    gate.tau.fill_(0.3)
    gate.chi.fill_(0.7)
    other = _gate(hidden=(32, 32))
    with torch.no_grad():
        for p in other.parameters():
            p.add_(1.0)
    other.load_state_dict(gate.state_dict())
    obs = torch.rand(5, 2)
    assert float(other.tau) == 0.3 and float(other.chi) == 0.7
    assert torch.equal(other.classifier(obs), gate.classifier(obs))


def test_method_builds_its_gate_from_the_env_specs(aperture_cfg):
    env = make_env(aperture_cfg)
    method = SafeDAgger(
        "safe_dagger",
        threshold=QuantileThreshold(0.8),
        discrepancy_threshold=QuantileThreshold(0.8),
        classifier=CLASSIFIER,
    )
    gate = method.make_gate(env)
    obs_dim = env.observation_spec["observation"].shape[-1]
    assert gate.classifier.obs_center.numel() == obs_dim
    assert gate.act_scale.numel() == env.action_spec.shape[-1]
    assert len(method.extra_hooks()) == 1
    with pytest.raises(ValueError, match="needs the env"):
        method.make_gate(None)


@pytest.mark.parametrize(
    ("classifier", "message"),
    [
        ({**CLASSIFIER, "depth": 3}, r"method.classifier.depth: unknown key"),
        ({"hidden": [8], "heldout_fraction": 0.3, "fit": {"steps": 10}}, r"method.classifier: missing \['balanced'\]"),
    ],
)
def test_bad_classifier_settings_are_named(classifier, message):
    with pytest.raises(ValueError, match=message):
        SafeDAgger(
            "safe_dagger",
            threshold=QuantileThreshold(0.8),
            discrepancy_threshold=FixedThreshold(0.1),
            classifier=classifier,
        )


def test_a_threshold_without_a_rule_is_named():
    with pytest.raises(ValueError, match="method.discrepancy_threshold = 0.2"):
        SafeDAgger(
            "safe_dagger",
            threshold=QuantileThreshold(0.8),
            discrepancy_threshold=0.2,  # pyright: ignore[reportArgumentType]  (the wrong type under test)
            classifier=CLASSIFIER,
        )


@pytest.mark.parametrize("fraction", [-0.1, 1.0, "a"])
def test_a_bad_heldout_fraction_is_named(fraction):
    with pytest.raises(ValueError, match=f"method.classifier.heldout_fraction = {fraction!r}: expected a fraction in"):
        SafeDAgger(
            "safe_dagger",
            threshold=QuantileThreshold(0.8),
            discrepancy_threshold=FixedThreshold(0.1),
            classifier={**CLASSIFIER, "heldout_fraction": fraction},
        )


def test_the_policy_is_fitted_without_the_heldout_episodes_and_the_classifier_on_them(tmp_path):
    """A smoke run of safe_dagger: each refit holds whole episodes out of the policy's fit (metrics say how
    many frames) and the classifier is fitted on exactly those frames."""
    from hydra import compose, initialize_config_dir

    from dpiil_rl.records.run_files import read_jsonl
    from dpiil_rl.training.factory import build_trainer
    from tests.conftest import ROOT

    with initialize_config_dir(str(ROOT / "configs"), version_base="1.3"):
        cfg = compose(
            "config",
            overrides=["method=safe_dagger", "experiment=smoke", "protocol.demo_episodes=3", "protocol.iterations=1"],
        )
    trainer = build_trainer(cfg, tmp_path)
    trainer.train()
    rows = read_jsonl(tmp_path / "metrics.jsonl")
    for row in rows:
        assert 0 < row["train/heldout_frames"] < row["dataset_size"]
        assert row["safe/classifier_frames"] == row["train/heldout_frames"]
    assert trainer.heldout is not None and int(trainer.heldout.sum()) == rows[-1]["train/heldout_frames"]
