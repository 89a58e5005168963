import torch
from tensordict import TensorDict

from dpiil_rl.methods.dpiil_mu import DPIILMu
from dpiil_rl.modules.threshold import FixedThreshold


def test_risk_ignores_the_speed_spread():
    method = DPIILMu("dpiil_mu", threshold=FixedThreshold(0.0))
    td = TensorDict(
        {
            "action_var": torch.full((2, 1), 3e-4),
            "speed_mu": torch.full((2, 1), 0.05),
            "speed_sigma": torch.tensor([[0.001], [0.5]]),
        },
        batch_size=[2],
    )
    risk = method.risk(td)
    assert torch.allclose(risk, torch.full((2, 1), 3e-4 / 0.05))


def test_unknown_option_is_named():
    import pytest

    with pytest.raises(ValueError, match="method.tau: unknown option"):
        DPIILMu("dpiil_mu", threshold=FixedThreshold(0.0), tau=3)
