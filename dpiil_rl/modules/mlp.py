"""A plain MLP (ReLU between layers) for the gates' own networks: the success critic, the discrepancy classifier."""

from __future__ import annotations

from typing import Sequence

from torch import nn


def mlp(in_features: int, out_features: int, hidden: Sequence[int]) -> nn.Sequential:
    layers: list[nn.Module] = []
    sizes = [in_features, *hidden]
    for a, b in zip(sizes[:-1], sizes[1:]):
        layers += [nn.Linear(a, b), nn.ReLU()]
    layers.append(nn.Linear(sizes[-1], out_features))
    return nn.Sequential(*layers)
