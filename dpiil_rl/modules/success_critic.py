"""A critic of task success ``Q(s, a) ∈ (0, 1)``: the discounted probability that the robot's policy,
started by action ``a`` in state ``s``, reaches the goal (ThriftyDAgger's safety critic).

It is trained by temporal differences on executed transitions (robot's and expert's alike) with
reward 1 on success and episode ends (success, collision, leaving the task space, timeout) as
terminal: ``y = r + γ (1 − done) Q̄(s', π(s'))`` with a Polyak-averaged target ``Q̄`` and a binary
cross-entropy loss, successes over-sampled in each minibatch (they are one step per episode).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Sequence

import torch
from torch import nn
from torch.nn import functional as F

from dpiil_rl.modules.fitting import FitSettings, seeded_reset
from dpiil_rl.modules.speed_head import mlp


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
            raise ValueError(f"method.critic.positive_fraction = {self.positive_fraction}: expected a fraction in [0, 1)")


class SuccessCritic(nn.Module):
    def __init__(
        self, obs_low: torch.Tensor, obs_high: torch.Tensor, act_low: torch.Tensor, act_high: torch.Tensor,
        hidden: Sequence[int] = (128, 128),
    ) -> None:
        super().__init__()
        low, high = torch.cat([obs_low, act_low]).float(), torch.cat([obs_high, act_high]).float()
        self.register_buffer("center", (high + low) / 2)
        self.register_buffer("scale", ((high - low) / 2).clamp_min(1e-6))
        self.net = mlp(self.center.numel(), 1, list(hidden))

    def logits(self, obs: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        x = (torch.cat([obs.float(), action.float()], -1) - self.center) / self.scale
        return self.net(x)

    def forward(self, obs: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        """``Q(s, a)`` ``[*batch, 1]``."""
        return torch.sigmoid(self.logits(obs, action))

    def _reset(self) -> None:
        for m in self.net:
            if isinstance(m, nn.Linear):
                m.reset_parameters()

    def fit(
        self, obs: torch.Tensor, action: torch.Tensor, next_obs: torch.Tensor, next_action: torch.Tensor,
        success: torch.Tensor, done: torch.Tensor, settings: FitSettings, targets: CriticTargets,
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
        target = copy.deepcopy(self.net).requires_grad_(False)
        params, target_params = list(self.net.parameters()), list(target.parameters())
        opt = torch.optim.Adam(params, lr=settings.lr, weight_decay=settings.weight_decay, foreach=True)
        losses = []
        self.train()
        for _ in range(settings.num_steps(n)):
            idx = torch.randint(0, n, (b,), generator=generator)
            if k:
                idx[:k] = positives[torch.randint(0, positives.numel(), (k,), generator=generator)]
            with torch.no_grad():
                x_next = (torch.cat([next_obs[idx].float(), next_action[idx].float()], -1) - self.center) / self.scale
                y = r[idx] + targets.gamma * (1.0 - d[idx]) * torch.sigmoid(target(x_next))
            loss = F.binary_cross_entropy_with_logits(self.logits(obs[idx], action[idx]), y)
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
            with torch.no_grad():
                torch._foreach_lerp_(target_params, params, targets.tau)
            losses.append(loss.item())
        self.eval()
        return losses
