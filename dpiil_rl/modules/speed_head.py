"""Gaussian speed head ``N(v | μ_λ(s), σ²_λ(s))`` trained by NLL on the expert's speeds (paper eq. 2-4).

``v = f_v(s_t, s_{t+1}) = ‖pos_{t+1} − pos_t‖²``. Speeds are modelled in units of the dataset's
mean speed (a buffer refreshed at every fit) so one architecture fits any task's scale.
"""

from __future__ import annotations

import math
from typing import Callable, Sequence

import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase
from torch.nn import functional as F

from dpiil_rl.modules.ensemble_mlp import EnsembleMLP
from dpiil_rl.modules.fitting import FitSettings, seeded_reset
from dpiil_rl.modules.joint_fit import FitJob, fit_jointly


def speed_loss(min_sigma: float) -> Callable[[torch.Tensor, torch.Tensor], torch.Tensor]:
    """Each member's Gaussian negative log-likelihood (``GaussianNLLLoss(full=True)``) of the relative
    speeds ``[M, b, 1]`` under its ``μ, σ`` (softplus of its two outputs, floored at ``min_sigma``)."""

    def loss(pred: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
        mu = F.softplus(pred[..., :1]) + min_sigma
        var = (F.softplus(pred[..., 1:]) + min_sigma).pow(2).clamp_min(1e-6)
        nll = 0.5 * (torch.log(var) + (target - mu) ** 2 / var) + 0.5 * math.log(2 * math.pi)
        return nll.mean(dim=(1, 2))

    return loss


class SpeedHead(TensorDictModuleBase):
    """Writes ``speed_mu`` and ``speed_sigma`` (``[*batch, 1]``, same units as ``v``).

    The network is a one-member :class:`~dpiil_rl.modules.ensemble_mlp.EnsembleMLP`, so its refits run
    through :func:`~dpiil_rl.modules.joint_fit.fit_jointly` like the actor's (several runs in one loop).

    ``inputs`` are the dimensions of the observation the head reads (all of them when None): a precision
    model that must not read the robot's current speed back from the state is given the state without its
    velocities (``modules.speed_head.ignore``, :func:`~dpiil_rl.training.factory.make_speed_head`)."""

    obs_center: torch.Tensor  # buffers (registered in __init__)
    obs_scale: torch.Tensor
    v_scale: torch.Tensor

    def __init__(
        self,
        obs_low: torch.Tensor,
        obs_high: torch.Tensor,
        hidden: Sequence[int] = (128, 128),
        min_sigma: float = 1e-3,
        observation_key: str = "observation",
        inputs: Sequence[int] | None = None,
    ) -> None:
        super().__init__()
        self.inputs: torch.Tensor | None = None
        if inputs is not None:
            self.inputs = torch.as_tensor(list(inputs), dtype=torch.long)
            if self.inputs.numel() == 0:
                raise ValueError("speed_head inputs = []: expected at least one observation dimension to read")
            obs_low, obs_high = obs_low[self.inputs], obs_high[self.inputs]
        if min_sigma <= 0:
            raise ValueError(f"speed_head.min_sigma = {min_sigma}: expected a positive floor (relative units)")
        self.in_keys = [observation_key]
        self.out_keys = ["speed_mu", "speed_sigma"]
        self.observation_key = observation_key
        self.min_sigma = float(min_sigma)
        self.register_buffer("obs_center", ((obs_high + obs_low) / 2).float())
        self.register_buffer("obs_scale", ((obs_high - obs_low) / 2).float().clamp_min(1e-6))
        self.register_buffer("v_scale", torch.ones(()))
        self.net = EnsembleMLP(1, self.obs_center.numel(), 2, list(hidden))

    def _read(self, obs: torch.Tensor) -> torch.Tensor:
        """The dimensions of ``obs`` the head reads."""
        return obs if self.inputs is None else obs[..., self.inputs]

    def _relative(self, obs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        x = (self._read(obs).float() - self.obs_center) / self.obs_scale
        out = self.net(x.reshape(1, -1, x.shape[-1]))[0].reshape(*x.shape[:-1], 2)
        mu = F.softplus(out[..., :1]) + self.min_sigma
        sigma = F.softplus(out[..., 1:]) + self.min_sigma
        return mu, sigma

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        mu, sigma = self._relative(tensordict.get(self.observation_key))
        tensordict.set("speed_mu", mu * self.v_scale)
        tensordict.set("speed_sigma", sigma * self.v_scale)
        return tensordict

    def fit_job(
        self, obs: torch.Tensor, speed: torch.Tensor, settings: FitSettings, generator: torch.Generator
    ) -> FitJob:
        """Prepare a refit on the observed speeds (fresh weights if ``settings.reinit``; speeds in units of
        their mean); :func:`~dpiil_rl.modules.joint_fit.fit_jointly` with :func:`speed_loss` runs it."""
        if obs.shape[0] == 0:
            raise ValueError("cannot fit the speed head on an empty dataset")
        if settings.reinit:
            seeded_reset(self.net.reset_parameters, generator)
        v = speed.float().reshape(-1, 1)
        self.v_scale.fill_(float(v.mean().clamp_min(1e-12)))
        x = ((self._read(obs).float() - self.obs_center) / self.obs_scale).detach()
        layers = list(self.net.linears)
        return FitJob(
            [layer.weight for layer in layers],
            [layer.bias for layer in layers],
            x,
            (v / self.v_scale).detach(),
            settings,
            generator,
        )

    def fit(
        self, obs: torch.Tensor, speed: torch.Tensor, settings: FitSettings, generator: torch.Generator
    ) -> list[float]:
        """Minimise the Gaussian NLL of the observed speeds; returns the loss curve."""
        job = self.fit_job(obs, speed, settings, generator)
        fit_jointly([job], speed_loss(self.min_sigma))
        return job.losses
