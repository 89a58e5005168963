"""A classifier of where the policy departs from the expert: ``P(d(s) > τ | s)`` with
``d(s) = ‖π(s) − a*(s)‖²`` (SafeDAgger's safety policy, LazyDAgger's ``f_σ``).

It reads the state only, so it can be asked before the expert is: the robot requests help where it
*predicts* that its action would differ from the expert's by more than τ. Inputs are scaled to
[-1, 1] with the observation spec's bounds, as every other network here.
"""

from __future__ import annotations

from typing import Sequence

import torch
from torch import nn
from torch.nn import functional as F

from dpiil_rl.modules.fitting import FitSettings, minibatch_fit, seeded_reset
from dpiil_rl.modules.mlp import mlp


class DiscrepancyClassifier(nn.Module):
    obs_center: torch.Tensor  # buffers (registered in __init__)
    obs_scale: torch.Tensor

    def __init__(self, obs_low: torch.Tensor, obs_high: torch.Tensor, hidden: Sequence[int] = (128, 128)) -> None:
        super().__init__()
        self.register_buffer("obs_center", ((obs_high + obs_low) / 2).float())
        self.register_buffer("obs_scale", ((obs_high - obs_low) / 2).float().clamp_min(1e-6))
        self.net = mlp(self.obs_center.numel(), 1, list(hidden))

    def logits(self, obs: torch.Tensor) -> torch.Tensor:
        return self.net((obs.float() - self.obs_center) / self.obs_scale)

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        """``P(d(s) > τ)`` ``[*batch, 1]``."""
        return torch.sigmoid(self.logits(obs))

    def _reset(self) -> None:
        for m in self.net:
            if isinstance(m, nn.Linear):
                m.reset_parameters()

    def fit(
        self,
        obs: torch.Tensor,
        unsafe: torch.Tensor,
        settings: FitSettings,
        generator: torch.Generator,
        balanced: bool = True,
    ) -> list[float]:
        """Binary cross-entropy on ``(s, d(s) > τ)``; returns the loss curve.

        ``balanced`` weighs the two classes equally (τ flags a minority of the states, 20% by the
        paper's protocol; unweighted, a small net would learn "always safe" first).
        """
        n = obs.shape[0]
        if n == 0:
            raise ValueError("cannot fit the discrepancy classifier on an empty dataset")
        if settings.reinit:
            seeded_reset(self._reset, generator)
        y = unsafe.float().reshape(n, 1)
        positives = float(y.sum())
        pos_weight = None
        if balanced and 0.0 < positives < n:
            pos_weight = torch.tensor([(n - positives) / positives])

        def loss_of(idx: torch.Tensor) -> torch.Tensor:
            return F.binary_cross_entropy_with_logits(self.logits(obs[idx]), y[idx], pos_weight=pos_weight)

        return minibatch_fit(self, settings, n, generator, loss_of)
