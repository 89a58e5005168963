import pytest
import torch
from tensordict import TensorDict
from tensordict.nn import TensorDictSequential

from dpiil_rl.collectors.expert_switch import QUERIED_KEY
from dpiil_rl.methods.lazy_dagger import LazyDAgger, LazyGate
from dpiil_rl.methods.safe_dagger import DiscrepancyGate
from dpiil_rl.modules.discrepancy_classifier import DiscrepancyClassifier
from dpiil_rl.modules.fitting import FitSettings
from dpiil_rl.modules.threshold import QuantileThreshold
from tests.mocks.constant_expert import ConstantExpert, ConstantPerson

LOW, HIGH = torch.tensor([-1.0, -1.0]), torch.tensor([1.0, 1.0])
CLASSIFIER = {"hidden": [16], "balanced": True, "heldout_fraction": 0.3, "fit": {"steps": 10}}


def _gate(expert, tau=0.04, beta_back=0.02) -> LazyGate:
    # a logistic classifier reading x alone: P(unsafe) = sigmoid(20 x), χ = 0.5, i.e. risky iff x > 0
    classifier = DiscrepancyClassifier(LOW, HIGH, hidden=[])
    layer = classifier.net[0]
    assert isinstance(layer, torch.nn.Linear)
    with torch.no_grad():
        layer.weight.copy_(torch.tensor([[20.0, 0.0]]))
        layer.bias.zero_()
    safety = DiscrepancyGate(classifier, LOW, HIGH, QuantileThreshold(0.8), QuantileThreshold(0.8))
    safety.tau.fill_(tau)
    safety.chi.fill_(0.5)
    gate = LazyGate(safety, expert, QuantileThreshold(0.2))
    gate.beta_back.fill_(beta_back)
    return gate


def _td(x, action, first=False):
    return TensorDict(
        {
            "observation": torch.tensor([[x, 0.0]]),
            "policy_action": torch.tensor([action]),
            "is_init": torch.tensor([[first]]),
        },
        batch_size=[1],
    )


def test_control_returns_only_once_the_robot_is_within_beta_r_of_the_expert():
    gate = _gate(ConstantExpert([0.0, 0.0]))  # τ = 0.04, β_R = 0.02
    assert not bool(gate(_td(-0.5, [0.3, 0.0], first=True))["expert_mode"])  # predicted safe: robot drives
    assert bool(gate(_td(0.5, [0.3, 0.0]))["expert_mode"])  # predicted unsafe: expert takes over
    # predicted safe again, but the robot still departs (gap 0.09 > τ): a memoryless gate would hand back here
    td = gate(_td(-0.5, [0.3, 0.0]))
    assert bool(td["expert_mode"]) and QUERIED_KEY in td.keys()
    assert bool(gate(_td(-0.5, [0.17, 0.0]))["expert_mode"])  # gap 0.029: below τ, above β_R: still the expert
    assert not bool(gate(_td(-0.5, [0.1, 0.0]))["expert_mode"])  # gap 0.01 < β_R: hands back
    assert not bool(gate(_td(-0.5, [0.3, 0.0], first=True))["expert_mode"])  # a new episode starts with the robot


def test_hand_back_is_tested_even_where_the_classifier_still_predicts_unsafe():
    gate = _gate(ConstantExpert([0.0, 0.0]))
    gate(_td(0.5, [0.3, 0.0], first=True))
    assert not bool(gate(_td(0.5, [0.05, 0.0]))["expert_mode"])  # the measured gap decides, not the prediction


def test_with_a_person_control_returns_only_once_they_drive_and_agree():
    person = ConstantPerson([0.0, 0.0], driving=False)
    gate = _gate(person)
    assert bool(gate(_td(0.5, [0.01, 0.0], first=True))["expert_mode"])
    assert bool(gate(_td(-0.5, [0.01, 0.0]))["expert_mode"])  # the still device "agrees": they have not taken over
    person.driving = True
    assert not bool(gate(_td(-0.5, [0.01, 0.0]))["expert_mode"])


def test_refit_and_calibration_go_through_the_safety_gate():
    gate = _gate(ConstantExpert([0.0, 0.0]))
    g = torch.Generator().manual_seed(0)
    obs = torch.rand(500, 2, generator=g) * 2 - 1
    out = gate.fit_classifier(obs, obs, torch.zeros(500, 2), FitSettings(steps=20), g)
    d = (obs**2).sum(-1)  # the policy's gap to an expert commanding 0 everywhere
    assert out["safe/tau"] == pytest.approx(float(torch.quantile(d.double(), 0.8)))
    assert out["lazy/beta_back"] == pytest.approx(float(torch.quantile(d.double(), 0.2)))
    assert float(gate.beta_back) == out["lazy/beta_back"]
    out = gate.calibrate(TensorDict({"observation": obs}, batch_size=[500]))
    assert float(gate.chi) == out["chi"]


def test_a_hand_back_threshold_at_or_above_tau_is_refused():
    gate = _gate(ConstantExpert([0.0, 0.0]))
    gate.back_rule = QuantileThreshold(0.9)  # above τ's 0.8-quantile: no hysteresis, the wrong way round
    obs = torch.rand(200, 2, generator=torch.Generator().manual_seed(1)) * 2 - 1
    with pytest.raises(ValueError, match=r"β_R = .* > τ"):
        gate.fit_classifier(obs, obs, torch.zeros(200, 2), FitSettings(steps=5), torch.Generator().manual_seed(0))


def test_back_threshold_and_the_expert_are_checked():
    with pytest.raises(ValueError, match="method.back_threshold = 0.5"):
        LazyDAgger(
            "lazy_dagger",
            back_threshold=0.5,  # pyright: ignore[reportArgumentType]  (the wrong type under test)
            threshold=QuantileThreshold(0.8),
            discrepancy_threshold=QuantileThreshold(0.8),
            classifier=CLASSIFIER,
        )
    method = LazyDAgger(
        "lazy_dagger",
        back_threshold=QuantileThreshold(0.2),
        threshold=QuantileThreshold(0.8),
        discrepancy_threshold=QuantileThreshold(0.8),
        classifier=CLASSIFIER,
    )
    with pytest.raises(ValueError, match="needs the expert source"):
        method.make_gate(None, None)


def test_supervisor_noise_perturbs_what_the_robot_executes_not_the_label(tmp_path):
    from hydra import compose, initialize_config_dir

    from dpiil_rl.training.factory import build_trainer
    from tests.conftest import ROOT

    with initialize_config_dir(str(ROOT / "configs"), version_base="1.3"):
        cfg = compose("config", overrides=["method=lazy_dagger", "method.supervisor_noise=0.3", "experiment=smoke"])
    trainer = build_trainer(cfg, tmp_path / "run")
    gate = trainer.gate
    assert isinstance(gate, LazyGate) and isinstance(trainer.interactive_policy, TensorDictSequential)
    assert gate.after_switch is not None and gate.after_switch in list(trainer.interactive_policy.module)
    gate.safety.chi.fill_(-1.0)  # every state is predicted unsafe: the expert drives
    start = trainer.collector.env.reset()
    td = trainer.interactive_policy(start.clone())
    assert bool(td["expert_mode"].all())
    assert not torch.allclose(td["action"], td["expert_action"])  # the robot executes a perturbed command...
    gate.after_switch.std = 0.0
    td = trainer.interactive_policy(start.clone())
    assert torch.equal(td["action"], td["expert_action"])  # ...while the label is the command the expert gave
    with pytest.raises(ValueError, match="method.supervisor_noise = -1"):
        LazyDAgger(
            "lazy_dagger",
            back_threshold=QuantileThreshold(0.2),
            supervisor_noise=-1,
            threshold=QuantileThreshold(0.8),
            discrepancy_threshold=QuantileThreshold(0.8),
            classifier=CLASSIFIER,
        )
