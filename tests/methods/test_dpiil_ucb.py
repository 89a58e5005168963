import torch
from tensordict import TensorDict

from dpiil_rl.methods.dpiil_ucb import DPIILUCB
from dpiil_rl.modules.threshold import FixedThreshold


def test_risk_uses_the_speed_upper_confidence_bound():
    td = TensorDict(
        {
            "action_var": torch.tensor([[2e-4]]),
            "speed_mu": torch.tensor([[0.03]]),
            "speed_sigma": torch.tensor([[0.01]]),
        },
        batch_size=[1],
    )
    method = DPIILUCB("dpiil_ucb", threshold=FixedThreshold(1e-3))
    assert torch.allclose(method.risk(td), torch.tensor([[2e-4 / 0.04]]))
    gate = method.make_gate()
    gate.calibrate(td)
    assert bool(gate(td)["expert_mode"])  # 5e-3 > 1e-3


def test_slower_steadier_demonstrations_mean_higher_risk_for_the_same_uncertainty():
    method = DPIILUCB("dpiil_ucb", threshold=FixedThreshold(0.0))
    var = torch.full((2, 1), 1e-4)
    td = TensorDict(
        {"action_var": var, "speed_mu": torch.tensor([[0.02], [0.2]]), "speed_sigma": torch.tensor([[0.005], [0.08]])},
        batch_size=[2],
    )
    risk = method.risk(td)
    assert risk[0] > 10 * risk[1]
