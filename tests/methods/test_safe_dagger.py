import pytest
import torch
from tensordict import TensorDict

from dpiil_rl.envs.factory import make_env
from dpiil_rl.methods.safe_dagger import DiscrepancyGate, SafeDAgger
from dpiil_rl.modules.discrepancy_classifier import DiscrepancyClassifier
from dpiil_rl.modules.fitting import FitSettings
from dpiil_rl.modules.threshold import FixedThreshold, QuantileThreshold

LOW, HIGH = torch.tensor([-1.0, -1.0]), torch.tensor([1.0, 1.0])
CLASSIFIER = {"hidden": [32, 32], "balanced": True, "fit": {"steps": 600, "batch_size": 128, "lr": 3e-3}}


def _gate(act_low=LOW, act_high=HIGH, hidden=(32, 32)) -> DiscrepancyGate:
    torch.manual_seed(0)
    return DiscrepancyGate(DiscrepancyClassifier(LOW, HIGH, hidden), act_low, act_high,
                           QuantileThreshold(0.8), QuantileThreshold(0.8))


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
    method = SafeDAgger("safe_dagger", threshold=QuantileThreshold(0.8), discrepancy_threshold=QuantileThreshold(0.8),
                        classifier=CLASSIFIER)
    gate = method.make_gate(env)
    obs_dim = env.observation_spec["observation"].shape[-1]
    assert gate.classifier.obs_center.numel() == obs_dim
    assert gate.act_scale.numel() == env.action_spec.shape[-1]
    assert len(method.extra_hooks()) == 1
    with pytest.raises(ValueError, match="needs the env"):
        method.make_gate(None)


@pytest.mark.parametrize(("classifier", "message"), [
    ({**CLASSIFIER, "depth": 3}, r"method.classifier.depth: unknown key"),
    ({"hidden": [8], "fit": {"steps": 10}}, r"method.classifier: missing \['balanced'\]"),
])
def test_bad_classifier_settings_are_named(classifier, message):
    with pytest.raises(ValueError, match=message):
        SafeDAgger("safe_dagger", threshold=QuantileThreshold(0.8), discrepancy_threshold=FixedThreshold(0.1),
                   classifier=classifier)


def test_a_threshold_without_a_rule_is_named():
    with pytest.raises(ValueError, match="method.discrepancy_threshold = 0.2"):
        SafeDAgger("safe_dagger", threshold=QuantileThreshold(0.8), discrepancy_threshold=0.2, classifier=CLASSIFIER)
