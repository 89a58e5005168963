"""Test-only gate: expert mode follows a fixed per-step schedule (indexed by the env's step count)."""

from __future__ import annotations

from typing import Sequence

import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase


class ScheduleGate(TensorDictModuleBase):
    def __init__(self, schedule: Sequence[bool]) -> None:
        super().__init__()
        self.in_keys = ["step_count"]
        self.out_keys = ["expert_mode", "risk"]
        self.schedule = torch.tensor(list(schedule), dtype=torch.bool)

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        step = tensordict.get("step_count").clamp_max(len(self.schedule) - 1)
        tensordict.set("expert_mode", self.schedule[step])
        tensordict.set("risk", self.schedule[step].float())
        return tensordict


class ZeroActor(TensorDictModuleBase):
    """A learner that never moves."""

    def __init__(self) -> None:
        super().__init__()
        self.in_keys = ["observation"]
        self.out_keys = ["policy_action"]

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        tensordict.set("policy_action", torch.zeros_like(tensordict.get("observation")))
        return tensordict
