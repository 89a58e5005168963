"""``E`` independent MLPs as one batched-matmul network: weights ``[E, in, out]``, ``torch.baddbmm`` per layer.

The ensemble actor's members, the speed head (one member), and in a joint refit the members of several
runs side by side (:mod:`dpiil_rl.modules.joint_fit`) are all this network.
"""

from __future__ import annotations

import math
from typing import Sequence, cast

import torch
from torch import nn


def mlp_forward(weights: Sequence[torch.Tensor], biases: Sequence[torch.Tensor], x: torch.Tensor) -> torch.Tensor:
    """The stacked members' MLP (ReLU between layers) on ``x`` ``[M, b, in]``."""
    for i, (w, b) in enumerate(zip(weights, biases)):
        x = torch.baddbmm(b, x, w)
        if i < len(weights) - 1:
            x = torch.relu(x)
    return x


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

    @property
    def linears(self) -> Sequence[EnsembleLinear]:
        """``layers`` as what they hold (to a type checker an ``nn.ModuleList`` holds plain modules)."""
        return cast("Sequence[EnsembleLinear]", self.layers)

    def reset_parameters(self) -> None:
        for layer in self.linears:
            layer.reset_parameters()

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return mlp_forward([layer.weight for layer in self.linears], [layer.bias for layer in self.linears], x)
