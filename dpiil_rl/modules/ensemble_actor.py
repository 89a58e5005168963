"""Ensemble policy: E MLPs trained by MSE on expert actions; their spread is the policy uncertainty σ²_θ.

The members run as one batched-matmul network (weights ``[E, in, out]``, ``torch.baddbmm``), the
fastest of the options measured on CPU for E = 5 (DESIGN section 7). Inputs are scaled to
[-1, 1] with the observation spec's bounds and outputs squashed into the action spec's bounds,
so no shape or scale lives in a config file.
"""

from __future__ import annotations

import math
from typing import Sequence

import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase
from torch import nn

from dpiil_rl.modules.fitting import FitSettings, adam, member_batches, seeded_reset


class EnsembleLinear(nn.Module):
    """``E`` independent linear layers applied to ``[E, B, in]`` in one batched matmul."""

    def __init__(self, members: int, in_features: int, out_features: int) -> None:
        super().__init__()
        self.weight = nn.Parameter(torch.empty(members, in_features, out_features))
        self.bias = nn.Parameter(torch.empty(members, 1, out_features))
        self.reset_parameters()

    def reset_parameters(self) -> None:
        bound = 1.0 / math.sqrt(self.weight.shape[1])
        nn.init.uniform_(self.weight, -bound, bound)
        nn.init.uniform_(self.bias, -bound, bound)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return torch.baddbmm(self.bias, x, self.weight)


class EnsembleMLP(nn.Module):
    def __init__(self, members: int, in_features: int, out_features: int, hidden: Sequence[int]) -> None:
        super().__init__()
        sizes = [in_features, *hidden, out_features]
        self.layers = nn.ModuleList(EnsembleLinear(members, a, b) for a, b in zip(sizes[:-1], sizes[1:]))

    def reset_parameters(self) -> None:
        for layer in self.layers:
            layer.reset_parameters()

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        for i, layer in enumerate(self.layers):
            x = layer(x)
            if i < len(self.layers) - 1:
                x = torch.relu(x)
        return x


class EnsembleActor(TensorDictModuleBase):
    """Writes ``policy_action`` (ensemble mean), ``action_var`` (σ²_θ, mean over action dims) and
    ``action_members`` (``[*batch, E, action_dim]``)."""

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

    def members(self, obs: torch.Tensor) -> torch.Tensor:
        """Every member's action ``[*batch, E, action_dim]``."""
        batch = obs.shape[:-1]
        y = self._normalised_members(obs.reshape(-1, obs.shape[-1])) * self.act_scale + self.act_center
        return y.transpose(0, 1).reshape(*batch, self.num_members, -1)

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        members = self.members(tensordict.get(self.observation_key))
        tensordict.set("policy_action", members.mean(-2))
        tensordict.set("action_var", members.var(-2, unbiased=False).mean(-1, keepdim=True))
        tensordict.set("action_members", members)
        return tensordict

    def fit(self, obs: torch.Tensor, actions: torch.Tensor, settings: FitSettings, generator: torch.Generator) -> list[float]:
        """Fit every member by MSE on (obs, expert action); returns the loss curve (mean over members)."""
        if obs.shape[0] == 0:
            raise ValueError("cannot fit the ensemble actor on an empty dataset")
        if settings.reinit:
            self.reset_parameters(generator)
        x = ((obs.float() - self.obs_center) / self.obs_scale).detach()
        y = ((actions.float() - self.act_center) / self.act_scale).clamp(-1, 1).detach()
        n = x.shape[0]
        boot = torch.randint(0, n, (self.num_members, n), generator=generator) if self.bootstrap else None
        steps = settings.num_steps(n)
        opt, scheduled = adam(self.net.parameters(), settings, steps)
        losses = []
        self.train()
        for _ in range(steps):
            idx = member_batches(n, self.num_members, settings.batch_size, generator, boot)  # [E, b]
            pred = torch.tanh(self.net(x[idx]))
            loss = ((pred - y[idx]) ** 2).mean(dim=(1, 2)).sum()
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
            scheduled()
            losses.append(loss.item() / self.num_members)
        self.eval()
        return losses

    def reset_parameters(self, generator: torch.Generator | None = None) -> None:
        if generator is None:
            self.net.reset_parameters()
        else:
            seeded_reset(self.net.reset_parameters, generator)
