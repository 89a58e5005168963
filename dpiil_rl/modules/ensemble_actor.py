"""Ensemble policy: E MLPs trained by MSE on expert actions; their spread is the policy uncertainty σ²_θ.

The members run as one batched-matmul network (weights ``[E, in, out]``, ``torch.baddbmm``), the
fastest of the options measured on CPU for E = 5 (docs/design.md); refits run through
:func:`~dpiil_rl.modules.joint_fit.fit_jointly`, so the refits of several runs can share one loop. Inputs are scaled to
[-1, 1] with the observation spec's bounds and outputs squashed into the action spec's bounds,
so no shape or scale lives in a config file.
"""

from __future__ import annotations

from typing import Sequence

import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase

from dpiil_rl.modules.ensemble_mlp import EnsembleMLP
from dpiil_rl.modules.fitting import FitSettings, seeded_reset
from dpiil_rl.modules.joint_fit import FitJob, fit_jointly


def action_loss(pred: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """Each member's mean squared error of its squashed output ``[M, b, A]`` against the scaled actions."""
    return ((torch.tanh(pred) - target) ** 2).mean(dim=(1, 2))


class EnsembleActor(TensorDictModuleBase):
    """Writes ``policy_action`` (ensemble mean), ``action_var`` (σ²_θ, mean over action dims) and
    ``action_members`` (``[*batch, E, action_dim]``)."""

    obs_center: torch.Tensor  # buffers (registered in __init__)
    obs_scale: torch.Tensor
    act_center: torch.Tensor
    act_scale: torch.Tensor

    def __init__(
        self,
        obs_low: torch.Tensor,
        obs_high: torch.Tensor,
        action_low: torch.Tensor,
        action_high: torch.Tensor,
        num_members: int = 5,
        hidden: Sequence[int] = (256, 256),
        bootstrap: bool = False,
        observation_key: str = "observation",
    ) -> None:
        if int(num_members) < 2:
            raise ValueError(f"actor.num_members = {num_members}: expected >= 2 (the variance needs two members)")
        super().__init__()
        self.in_keys = [observation_key]
        self.out_keys = ["policy_action", "action_var", "action_members"]
        self.observation_key = observation_key
        self.num_members = int(num_members)
        self.bootstrap = bool(bootstrap)
        self.register_buffer("obs_center", ((obs_high + obs_low) / 2).float())
        self.register_buffer("obs_scale", ((obs_high - obs_low) / 2).float().clamp_min(1e-6))
        self.register_buffer("act_center", ((action_high + action_low) / 2).float())
        self.register_buffer("act_scale", ((action_high - action_low) / 2).float().clamp_min(1e-6))
        self.net = EnsembleMLP(self.num_members, self.obs_center.numel(), self.act_center.numel(), list(hidden))

    def _normalised_members(self, obs: torch.Tensor) -> torch.Tensor:
        """Members' outputs in [-1, 1]: ``[E, B, A]`` for ``obs`` ``[B, obs_dim]``."""
        x = (obs.float() - self.obs_center) / self.obs_scale
        return torch.tanh(self.net(x.unsqueeze(0).expand(self.num_members, *x.shape)))

    #: compute a batch as rows ``pad_offset ..`` of a batch of ``pad_rows`` (zero rows around it, then dropped): a
    #: row's bits then do not depend on how many rows are evaluated with it nor where (a matrix product takes
    #: other kernels for other sizes, and for the rows of a last, partial block; so does the mean over the
    #: members: it is taken over the padded batch too)
    pad_rows: int | None = None
    pad_offset: int = 0

    def _padded_members(self, obs: torch.Tensor) -> tuple[torch.Tensor, slice]:
        """Every member's action ``[P, E, action_dim]`` for the rows of ``obs`` flattened (``P`` = their count, or
        ``pad_rows`` with the rows at ``pad_offset``), and where those rows are."""
        flat = obs.reshape(-1, obs.shape[-1])
        rows, first = flat.shape[0], 0
        if self.pad_rows is not None and rows < self.pad_rows:
            first = min(self.pad_offset, self.pad_rows - rows)
            padded = flat.new_zeros(self.pad_rows, flat.shape[-1])
            padded[first : first + rows] = flat
            flat = padded
        y = self._normalised_members(flat) * self.act_scale + self.act_center
        return y.transpose(0, 1).reshape(flat.shape[0], self.num_members, -1), slice(first, first + rows)

    def members(self, obs: torch.Tensor) -> torch.Tensor:
        """Every member's action ``[*batch, E, action_dim]``."""
        y, rows = self._padded_members(obs)
        return y[rows].reshape(*obs.shape[:-1], self.num_members, -1)

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        obs = tensordict.get(self.observation_key)
        y, rows = self._padded_members(obs)
        batch = obs.shape[:-1]
        tensordict.set("policy_action", y.mean(-2)[rows].reshape(*batch, -1))
        tensordict.set("action_var", y.var(-2, unbiased=False).mean(-1, keepdim=True)[rows].reshape(*batch, 1))
        tensordict.set("action_members", y[rows].reshape(*batch, self.num_members, -1))
        return tensordict

    def fit_job(
        self, obs: torch.Tensor, actions: torch.Tensor, settings: FitSettings, generator: torch.Generator
    ) -> FitJob:
        """Prepare a refit on (obs, expert action): fresh weights (if ``settings.reinit``), scaled data, each
        member's bootstrap resample; :func:`~dpiil_rl.modules.joint_fit.fit_jointly` runs it (alone or beside
        other runs' refits, with the same result)."""
        if obs.shape[0] == 0:
            raise ValueError("cannot fit the ensemble actor on an empty dataset")
        if settings.reinit:
            self.reset_parameters(generator)
        x = ((obs.float() - self.obs_center) / self.obs_scale).detach()
        y = ((actions.float() - self.act_center) / self.act_scale).clamp(-1, 1).detach()
        n = x.shape[0]
        boot = torch.randint(0, n, (self.num_members, n), generator=generator) if self.bootstrap else None
        layers = list(self.net.linears)
        return FitJob(
            [layer.weight for layer in layers], [layer.bias for layer in layers], x, y, settings, generator, boot
        )

    def fit(
        self, obs: torch.Tensor, actions: torch.Tensor, settings: FitSettings, generator: torch.Generator
    ) -> list[float]:
        """Fit every member by MSE on (obs, expert action); returns the loss curve (mean over members)."""
        job = self.fit_job(obs, actions, settings, generator)
        fit_jointly([job], action_loss)
        return job.losses

    def reset_parameters(self, generator: torch.Generator | None = None) -> None:
        if generator is None:
            self.net.reset_parameters()
        else:
            seeded_reset(self.net.reset_parameters, generator)
