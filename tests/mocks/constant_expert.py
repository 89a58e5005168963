"""Test-only expert source: always commands the same action; counts its lifecycle calls."""

from __future__ import annotations

from typing import Sequence

import torch
from tensordict import TensorDictBase

from dpiil_rl.experts.base import ExpertSource


class ConstantExpert(ExpertSource):
    def __init__(self, action: Sequence[float], labels_every_step: bool = True) -> None:
        super().__init__()
        self.action = torch.tensor(list(action), dtype=torch.float32)
        self.labels_every_step = labels_every_step
        self.calls = 0
        self.resets = 0

    def get_action(self, tensordict: TensorDictBase) -> torch.Tensor:
        self.calls += 1
        return self.action.expand(*tensordict.batch_size, -1).clone()

    def reset(self, mask: torch.Tensor) -> None:
        self.resets += int(mask.sum())


class ConstantPerson(ConstantExpert):
    """A person's source for one robot: their action is a demonstration only while they drive
    (``labelled``); before they take the robot their device commands "hold still" (zeros)."""

    labels_every_step = False

    def __init__(self, action: Sequence[float], driving: bool) -> None:
        super().__init__(action, labels_every_step=False)
        self.driving = driving

    def get_action(self, tensordict: TensorDictBase) -> torch.Tensor:
        self.labelled = torch.tensor([self.driving])
        return (
            super().get_action(tensordict) if self.driving else torch.zeros(*tensordict.batch_size, self.action.numel())
        )
