"""Noise added to the expert's *executed* action while the expert is in control (LazyDAgger).

The expert's label stays clean (``expert_action`` goes to the dataset as it was commanded); only
the action sent to the robot is perturbed, so the expert's own corrections visit states around
their path and the dataset covers the neighbourhood the robot will drift into. The noise is
Gaussian with a standard deviation given as a fraction of each action dim's half-range (the
action spec's units), clipped to the spec's bounds, from the gate's own seeded random stream
(checkpointed with the gate, so a resumed run draws the same noise).
"""

from __future__ import annotations

from typing import Any

import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase


class SupervisorNoise(TensorDictModuleBase):
    low: torch.Tensor  # buffers (registered in __init__)
    high: torch.Tensor

    def __init__(self, act_low: torch.Tensor, act_high: torch.Tensor, std: float, seed: int) -> None:
        if not float(std) >= 0.0:
            raise ValueError(
                f"method.supervisor_noise = {std}: expected a standard deviation >= 0 (a fraction of the action range)"
            )
        super().__init__()
        self.in_keys = ["action", "expert_mode"]
        self.out_keys = ["action"]
        self.std = float(std)
        self.register_buffer("low", act_low.float().clone())
        self.register_buffer("high", act_high.float().clone())
        self.generator = torch.Generator().manual_seed(int(seed))

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        if self.std == 0.0:
            return tensordict
        mode = tensordict.get("expert_mode")
        if not bool(mode.any()):
            return tensordict
        action = tensordict.get("action")
        scale = (self.high - self.low).to(action.device) / 2
        noise = torch.randn(action.shape, generator=self.generator).to(action.device) * self.std * scale
        noisy = torch.minimum(torch.maximum(action + noise, self.low.to(action.device)), self.high.to(action.device))
        tensordict.set("action", torch.where(mode, noisy, action))
        return tensordict

    def get_extra_state(self) -> Any:
        return {"generator": self.generator.get_state()}

    def set_extra_state(self, state: Any) -> None:
        self.generator.set_state(state["generator"])
