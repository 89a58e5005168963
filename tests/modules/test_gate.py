import pytest
import torch
from tensordict import TensorDict

from dpiil_rl.methods.dpiil_mu import DPIILMu
from dpiil_rl.methods.dpiil_ucb import DPIILUCB
from dpiil_rl.modules.threshold import FixedThreshold, QuantileThreshold


def _td():
    return TensorDict(
        {
            "action_var": torch.tensor([[1e-4], [1e-4], [4e-4], [1e-3]]),
            "speed_mu": torch.tensor([[0.2], [0.01], [0.1], [0.3]]),
            "speed_sigma": torch.tensor([[0.05], [0.01], [0.1], [0.2]]),
        },
        batch_size=[4],
    )


def test_dpiil_risk_is_precision_times_uncertainty():
    td = _td()
    ucb = DPIILUCB("dpiil_ucb", threshold=FixedThreshold(0.0)).risk(td)
    mu = DPIILMu("dpiil_mu", threshold=FixedThreshold(0.0)).risk(td)
    assert torch.allclose(ucb.squeeze(-1), torch.tensor([1e-4 / 0.25, 1e-4 / 0.02, 4e-4 / 0.2, 1e-3 / 0.5]))
    assert torch.allclose(mu.squeeze(-1), torch.tensor([1e-4 / 0.2, 1e-4 / 0.01, 4e-4 / 0.1, 1e-3 / 0.3]))


def test_gate_switches_above_chi_every_step():
    gate = DPIILUCB("dpiil_ucb", threshold=FixedThreshold(2.5e-3)).make_gate()
    assert not gate(_td())["expert_mode"].any()  # χ = inf until calibrated
    assert gate.calibrate(_td()) == 2.5e-3
    td = gate(_td())
    assert td["expert_mode"].squeeze(-1).tolist() == [False, True, False, False]  # risks 4e-4, 5e-3, 2e-3, 2e-3


def test_quantile_calibration_flags_the_top_fraction():
    risk = torch.rand(10_000, 1, generator=torch.Generator().manual_seed(0))
    chi = QuantileThreshold(0.8)(risk)
    assert abs(chi - 0.8) < 0.02
    assert abs(float((risk > chi).float().mean()) - 0.2) < 1e-3


def test_gate_calibrates_to_top_20_percent_of_training_risk():
    g = torch.Generator().manual_seed(1)
    td = TensorDict(
        {
            "action_var": torch.rand(1000, 1, generator=g) * 1e-3,
            "speed_mu": torch.rand(1000, 1, generator=g) + 0.1,
            "speed_sigma": torch.rand(1000, 1, generator=g) * 0.1,
        },
        batch_size=[1000],
    )
    gate = DPIILUCB("dpiil_ucb", threshold=QuantileThreshold(0.8)).make_gate()
    gate.calibrate(td)
    assert abs(float(gate(td)["expert_mode"].float().mean()) - 0.2) < 0.002


@pytest.mark.parametrize("q", [0.0, 1.0, -0.2, 1.5])
def test_quantile_outside_unit_interval_is_named(q):
    with pytest.raises(ValueError, match=f"quantile = {q}: expected a number strictly between 0 and 1"):
        QuantileThreshold(q)
