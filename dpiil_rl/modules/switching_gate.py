"""Gates with memory: whether the expert acts now depends on who acted at the previous step.

Risk gates are memoryless (``risk(s) > χ`` every step). Others are not: DAgger's random hand-overs
last a segment, ThriftyDAgger hands control back only when the robot agrees with the expert, and
an HG-DAgger expert keeps control until it judges the situation safe. :class:`SwitchingGate`
keeps the per-env mode of the previous step and forgets it at each episode's first step
(``is_init``), so subclasses only write the switching rule.
"""

from __future__ import annotations

from abc import abstractmethod
from typing import Sequence

import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase


class SwitchingGate(TensorDictModuleBase):
    """Writes ``expert_mode`` from :meth:`decide` (given the previous mode of each env)."""

    def __init__(
        self, in_keys: Sequence[str], out_keys: Sequence[str] = ("expert_mode",), batch_key: str = "observation"
    ) -> None:
        super().__init__()
        self.in_keys = [*in_keys, "is_init"]
        self.out_keys = list(out_keys)
        self.batch_key = batch_key
        self._mode: torch.Tensor | None = None

    def previous_mode(self, tensordict: TensorDictBase) -> torch.Tensor:
        """``[*batch, 1]`` bool: expert in control at the previous step of the same episode."""
        ref = tensordict.get(self.batch_key)
        shape = (*ref.shape[:-1], 1)
        previous = self._mode
        if previous is None or previous.shape != shape:
            previous = torch.zeros(shape, dtype=torch.bool, device=ref.device)
        is_init = tensordict.get("is_init", None)
        if is_init is not None:
            previous = previous & ~is_init.reshape(shape)
        return previous

    @abstractmethod
    def decide(self, tensordict: TensorDictBase, previous: torch.Tensor) -> torch.Tensor:
        """``[*batch, 1]`` bool expert mode for this step."""

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        mode = self.decide(tensordict, self.previous_mode(tensordict)).bool()
        self._mode = mode.clone()
        tensordict.set("expert_mode", mode)
        return tensordict

    def reset_history(self) -> None:
        """Forget every env's previous mode (start of a collection round)."""
        self._mode = None
