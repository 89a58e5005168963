"""Gaussian speed head ``N(v | μ_λ(s), σ²_λ(s))`` trained by NLL on the expert's speeds (paper eq. 2-4).

``v = f_v(s_t, s_{t+1}) = ‖pos_{t+1} − pos_t‖²``. Speeds are modelled in units of the dataset's
mean speed (a buffer refreshed at every fit) so one architecture fits any task's scale.
"""

from __future__ import annotations

from typing import Sequence

import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase
from torch import nn
from torch.nn import functional as F

from dpiil_rl.modules.fitting import FitSettings, minibatch_fit, seeded_reset


def mlp(in_features: int, out_features: int, hidden: Sequence[int]) -> nn.Sequential:
    layers: list[nn.Module] = []
    sizes = [in_features, *hidden]
    for a, b in zip(sizes[:-1], sizes[1:]):
        layers += [nn.Linear(a, b), nn.ReLU()]
    layers.append(nn.Linear(sizes[-1], out_features))
    return nn.Sequential(*layers)


class SpeedHead(TensorDictModuleBase):
    """Writes ``speed_mu`` and ``speed_sigma`` (``[*batch, 1]``, same units as ``v``)."""

    def __init__(
        self,
        obs_low: torch.Tensor,
        obs_high: torch.Tensor,
        hidden: Sequence[int] = (128, 128),
        min_sigma: float = 1e-3,
        observation_key: str = "observation",
    ) -> None:
        super().__init__()
        if min_sigma <= 0:
            raise ValueError(f"speed_head.min_sigma = {min_sigma}: expected a positive floor (relative units)")
        self.in_keys = [observation_key]
        self.out_keys = ["speed_mu", "speed_sigma"]
        self.observation_key = observation_key
        self.min_sigma = float(min_sigma)
        self.register_buffer("obs_center", ((obs_high + obs_low) / 2).float())
        self.register_buffer("obs_scale", ((obs_high - obs_low) / 2).float().clamp_min(1e-6))
        self.register_buffer("v_scale", torch.ones(()))
        self.net = mlp(self.obs_center.numel(), 2, list(hidden))

    def _relative(self, obs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        out = self.net((obs.float() - self.obs_center) / self.obs_scale)
        mu = F.softplus(out[..., :1]) + self.min_sigma
        sigma = F.softplus(out[..., 1:]) + self.min_sigma
        return mu, sigma

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        mu, sigma = self._relative(tensordict.get(self.observation_key))
        tensordict.set("speed_mu", mu * self.v_scale)
        tensordict.set("speed_sigma", sigma * self.v_scale)
        return tensordict

    def _reset_net(self) -> None:
        for m in self.net:
            if isinstance(m, nn.Linear):
                m.reset_parameters()

    def fit(self, obs: torch.Tensor, speed: torch.Tensor, settings: FitSettings, generator: torch.Generator) -> list[float]:
        """Minimise the Gaussian NLL of the observed speeds; returns the loss curve."""
        if obs.shape[0] == 0:
            raise ValueError("cannot fit the speed head on an empty dataset")
        if settings.reinit:
            seeded_reset(self._reset_net, generator)
        v = speed.float().reshape(-1, 1)
        self.v_scale.fill_(float(v.mean().clamp_min(1e-12)))
        target = (v / self.v_scale).detach()
        x = obs.float().detach()
        nll = nn.GaussianNLLLoss(full=True)

        def loss_of(idx: torch.Tensor) -> torch.Tensor:
            mu, sigma = self._relative(x[idx])
            return nll(mu, target[idx], sigma**2)

        return minibatch_fit(self, settings, x.shape[0], generator, loss_of)
