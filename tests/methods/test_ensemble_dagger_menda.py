import pytest
import torch
from tensordict import TensorDict

from dpiil_rl.collectors.expert_switch import ExpertSwitch
from dpiil_rl.methods.ensemble_dagger_menda import EnsembleDAggerMenda
from dpiil_rl.modules.threshold import FixedThreshold, QuantileThreshold
from dpiil_rl.training.factory import build_env
from tests.mocks.constant_expert import ConstantExpert


def _gate(aperture_cfg, tau: float, chi: float):
    env = build_env(aperture_cfg, 4, seed=0)
    method = EnsembleDAggerMenda(
        "ensemble_dagger_menda", threshold=FixedThreshold(chi), discrepancy_threshold=FixedThreshold(tau)
    )
    return method.make_gate(env, ConstantExpert([0.5, 0.0]))


def test_the_robot_acts_only_where_close_to_the_expert_and_sure(aperture_cfg):
    gate = _gate(aperture_cfg, tau=0.2, chi=0.01)
    gate.calibrate(
        TensorDict(
            {"action_var": torch.zeros(3, 1), "policy_action": torch.zeros(3, 2), "expert_action": torch.zeros(3, 2)},
            [3],
        )
    )
    # close & sure | far & sure | close & unsure | far & unsure (action bounds ±1: scale 1)
    td = TensorDict(
        {
            "observation": torch.zeros(4, 2),
            "policy_action": torch.tensor([[0.45, 0.0], [0.0, 0.0], [0.5, 0.0], [-0.5, 0.0]]),
            "action_var": torch.tensor([[0.0], [0.0], [0.1], [0.1]]),
            "is_init": torch.zeros(4, 1, dtype=torch.bool),
        },
        [4],
    )
    td = gate(td)
    assert td["expert_mode"].reshape(-1).tolist() == [False, True, True, True]
    assert torch.allclose(td["discrepancy"].reshape(-1), torch.tensor([0.05, 0.5, 0.0, 1.0]))
    td = ExpertSwitch(gate.expert)(td)
    assert bool(td["expert_queried"].all())  # monitoring: the expert is asked at every step, robot-driven ones too
    assert td["expert_labelled"].reshape(-1).tolist() == [False, True, True, True]  # only where the expert drives
    assert isinstance(gate.expert, ConstantExpert)
    assert gate.expert.calls == 1  # asked once per step: the switch reused the gate's answer


def test_calibration_flags_the_top_fifth_of_each_test(aperture_cfg):
    gate = _gate(aperture_cfg, tau=0.0, chi=0.0)
    gate.rule, gate.discrepancy_rule = QuantileThreshold(0.8), QuantileThreshold(0.8)
    g = torch.Generator().manual_seed(0)
    td = TensorDict(
        {
            "action_var": torch.rand(5000, 1, generator=g),
            "policy_action": torch.rand(5000, 2, generator=g),
            "expert_action": torch.zeros(5000, 2),
        },
        [5000],
    )
    out = gate.calibrate(td)
    assert 0.3 < out["train/flagged_fraction"] < 0.4  # two independent top-20% tests: 1 − 0.8² = 36%
    assert out["menda/tau"] > 0 and out["chi"] > 0


def test_rules_must_be_threshold_rules():
    with pytest.raises(ValueError, match="method.discrepancy_threshold"):
        EnsembleDAggerMenda(
            "ensemble_dagger_menda",
            threshold=FixedThreshold(0.1),
            discrepancy_threshold=0.3,  # pyright: ignore[reportArgumentType]  (the wrong type under test)
        )
