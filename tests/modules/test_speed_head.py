import torch
from tensordict import TensorDict

from dpiil_rl.modules.fitting import FitSettings
from dpiil_rl.modules.speed_head import SpeedHead


def test_recovers_a_heteroscedastic_function():
    """v ~ N(mu(x), sigma(x)^2) with mean and std both growing with x (like clearance)."""
    g = torch.Generator().manual_seed(0)
    torch.manual_seed(0)
    x = torch.rand(4000, 2, generator=g) * 2 - 1
    mu = 0.2 + 0.15 * (x[:, :1] + 1)  # 0.2 .. 0.5
    sigma = 0.01 + 0.04 * (x[:, :1] + 1)  # 0.01 .. 0.09
    v = mu + sigma * torch.randn(4000, 1, generator=g)
    head = SpeedHead(torch.tensor([-1.0, -1.0]), torch.tensor([1.0, 1.0]), hidden=(64, 64))
    head.fit(x, v, FitSettings(steps=2500, batch_size=256, lr=3e-3), g)
    probe = torch.tensor([[-0.8, 0.0], [0.0, 0.0], [0.8, 0.0]])
    out = head(TensorDict({"observation": probe}, batch_size=[3]))
    true_mu = 0.2 + 0.15 * (probe[:, :1] + 1)
    true_sigma = 0.01 + 0.04 * (probe[:, :1] + 1)
    assert torch.allclose(out["speed_mu"], true_mu, atol=0.02), out["speed_mu"]
    assert torch.allclose(out["speed_sigma"], true_sigma, atol=0.015), out["speed_sigma"]
    assert out["speed_sigma"][2] > 3 * out["speed_sigma"][0]  # the head sees the heteroscedasticity


def test_nll_matches_the_paper_loss():
    mu, sigma, y = torch.tensor([0.3, 0.1]), torch.tensor([0.05, 0.2]), torch.tensor([0.32, -0.1])
    ours = torch.nn.GaussianNLLLoss(full=True)(mu, y, sigma**2)
    paper = -torch.distributions.Normal(mu, sigma).log_prob(y).mean()
    assert torch.allclose(ours, paper)


def test_a_head_given_some_inputs_reads_only_those():
    """``inputs``: the head's output does not move with the dimensions it was told to ignore, and it still
    learns from the ones it reads (the precision without the robot's velocities, ``speed_head.ignore``)."""
    g = torch.Generator().manual_seed(0)
    torch.manual_seed(0)
    x = torch.rand(3000, 3, generator=g) * 2 - 1
    v = 0.2 + 0.15 * (x[:, :1] + 1) + 0.01 * torch.randn(3000, 1, generator=g)
    low, high = torch.full((3,), -1.0), torch.full((3,), 1.0)
    head = SpeedHead(low, high, hidden=(32, 32), inputs=[0, 2])
    assert head.obs_center.numel() == 2 and head.net.linears[0].weight.shape[1] == 2
    head.fit(x, v, FitSettings(steps=1500, batch_size=128, lr=3e-3), g)
    probe = torch.tensor([[-0.8, -1.0, 0.3], [-0.8, 1.0, 0.3], [0.8, 0.0, 0.3]])
    out = head(TensorDict({"observation": probe}, batch_size=[3]))
    assert torch.equal(out["speed_mu"][0], out["speed_mu"][1])  # dimension 1 is not read
    assert out["speed_mu"][2] > out["speed_mu"][0] + 0.15  # dimension 0 is


def test_a_head_needs_something_to_read():
    import pytest

    with pytest.raises(ValueError, match=r"speed_head inputs = \[\]"):
        SpeedHead(torch.zeros(2), torch.ones(2), inputs=[])
