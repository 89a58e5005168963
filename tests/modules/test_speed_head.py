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
