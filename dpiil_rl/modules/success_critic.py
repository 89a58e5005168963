"""A critic of task success ``Q(s, a) ∈ (0, 1)``: the discounted probability that the robot's policy,
started by action ``a`` in state ``s``, reaches the goal (ThriftyDAgger's safety critic).

It is trained by temporal differences on executed transitions (robot's and expert's alike) with
reward 1 on success and episode ends (success, collision, leaving the task space, timeout) as
terminal: ``y = r + γ (1 − done) min_j Q̄_j(s', π(s'))`` with Polyak-averaged targets ``Q̄_j`` and a
binary cross-entropy loss for each network, successes over-sampled in each minibatch (they are one
step per episode). The authors' code fits the same backup with a squared error on the sigmoid outputs;
both are minimised by the backup, cross-entropy keeps useful gradients near 0 and 1.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Sequence, cast

import torch
from torch import nn
from torch.nn import functional as F

from dpiil_rl.modules.fitting import FitSettings, adam, seeded_reset
from dpiil_rl.modules.mlp import mlp


@dataclass
class CriticTargets:
    """What a TD fit needs besides the network: discount, target smoothing, success over-sampling."""

    gamma: float = 0.99  # discount per step
    tau: float = 0.01  # Polyak rate of the target network per gradient step
    positive_fraction: float = 0.1  # share of each minibatch drawn from successful transitions

    def __post_init__(self) -> None:
        if not 0.0 < self.gamma <= 1.0:
            raise ValueError(f"method.critic.gamma = {self.gamma}: expected a discount in (0, 1]")
        if not 0.0 < self.tau <= 1.0:
            raise ValueError(f"method.critic.tau = {self.tau}: expected a rate in (0, 1]")
        if not 0.0 <= self.positive_fraction < 1.0:
            raise ValueError(
                f"method.critic.positive_fraction = {self.positive_fraction}: expected a fraction in [0, 1)"
            )


class SuccessCritic(nn.Module):
    """``q_networks`` independent networks; ``Q`` is the smallest of their values (the authors' code keeps
    two, ``q1`` and ``q2``, and reads the minimum: a pessimistic estimate of success)."""

    center: torch.Tensor  # buffers (registered in __init__)
    scale: torch.Tensor

    def __init__(
        self,
        obs_low: torch.Tensor,
        obs_high: torch.Tensor,
        act_low: torch.Tensor,
        act_high: torch.Tensor,
        hidden: Sequence[int] = (128, 128),
        q_networks: int = 2,
    ) -> None:
        super().__init__()
        if int(q_networks) < 1:
            raise ValueError(f"method.critic.q_networks = {q_networks}: expected at least one Q network")
        low, high = torch.cat([obs_low, act_low]).float(), torch.cat([obs_high, act_high]).float()
        self.register_buffer("center", (high + low) / 2)
        self.register_buffer("scale", ((high - low) / 2).clamp_min(1e-6))
        self.nets = nn.ModuleList(mlp(self.center.numel(), 1, list(hidden)) for _ in range(int(q_networks)))

    def _inputs(self, obs: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        return (torch.cat([obs.float(), action.float()], -1) - self.center) / self.scale

    def logits(self, obs: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        """Every network's logit ``[q_networks, *batch, 1]``."""
        x = self._inputs(obs, action)
        return torch.stack([net(x) for net in self.nets])

    def forward(self, obs: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        """``Q(s, a)`` ``[*batch, 1]``: the smallest of the networks' values."""
        return torch.sigmoid(self.logits(obs, action)).amin(0)

    def _reset(self) -> None:
        for net in cast("Sequence[nn.Sequential]", self.nets):  # what mlp() built
            for m in net:
                if isinstance(m, nn.Linear):
                    m.reset_parameters()

    def fit(
        self,
        obs: torch.Tensor,
        action: torch.Tensor,
        next_obs: torch.Tensor,
        next_action: torch.Tensor,
        success: torch.Tensor,
        done: torch.Tensor,
        settings: FitSettings,
        targets: CriticTargets,
        generator: torch.Generator,
    ) -> list[float]:
        """TD fit on transitions ``[n, ...]``; ``next_action = π(s')`` of the current policy. Loss curve."""
        n = obs.shape[0]
        if n == 0:
            raise ValueError("cannot fit the success critic: no transition has been recorded")
        if settings.reinit:
            seeded_reset(self._reset, generator)
        r, d = success.float().reshape(n, 1), done.float().reshape(n, 1)
        positives = (r > 0).reshape(-1).nonzero().reshape(-1)
        b = min(settings.batch_size, n)
        k = int(round(targets.positive_fraction * b)) if positives.numel() else 0
        target = copy.deepcopy(self.nets).requires_grad_(False)
        params: list[torch.Tensor] = list(self.nets.parameters())
        target_params: list[torch.Tensor] = list(target.parameters())
        steps = settings.num_steps(n)
        opt, scheduled = adam(params, settings, steps)
        losses = []
        self.train()
        for _ in range(steps):
            idx = torch.randint(0, n, (b,), generator=generator)
            if k:
                idx[:k] = positives[torch.randint(0, positives.numel(), (k,), generator=generator)]
            with torch.no_grad():
                x_next = self._inputs(next_obs[idx], next_action[idx])
                q_next = torch.stack([torch.sigmoid(net(x_next)) for net in target]).amin(0)  # the smallest, as Q
                y = r[idx] + targets.gamma * (1.0 - d[idx]) * q_next
            logits = self.logits(obs[idx], action[idx])
            loss = F.binary_cross_entropy_with_logits(logits, y.expand_as(logits)) * len(self.nets)
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
            scheduled()
            with torch.no_grad():
                # the _foreach ops are left out of torch.__all__ (torch.optim calls them the same way)
                torch._foreach_lerp_(target_params, params, targets.tau)  # pyright: ignore[reportPrivateImportUsage]
            losses.append(loss.item())
        self.eval()
        return losses
