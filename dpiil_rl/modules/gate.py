"""Gates decide, every step, whether the expert acts: they write ``risk`` and ``expert_mode``."""

from __future__ import annotations

from typing import Callable, Sequence

import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase

RiskFn = Callable[[TensorDictBase], torch.Tensor]
ThresholdRule = Callable[[torch.Tensor], float]


class RiskGate(TensorDictModuleBase):
    """``expert_mode = risk(s) > χ``, evaluated every step (control returns once the risk falls).

    ``risk_fn`` comes from the method (e.g. DPIIL_UCB: ``σ²_θ / (μ + σ)``); χ is a buffer, so it is
    saved with the policy, and :meth:`calibrate` resets it from the training data with ``rule``.
    """

    chi: torch.Tensor  # buffer (registered in __init__)

    def __init__(self, risk_fn: RiskFn, in_keys: Sequence[str], rule: ThresholdRule) -> None:
        super().__init__()
        self.in_keys = list(in_keys)
        self.out_keys = ["risk", "expert_mode"]
        self.risk_fn = risk_fn
        self.rule = rule
        self.register_buffer("chi", torch.tensor(float("inf"), dtype=torch.float64))

    def risk(self, tensordict: TensorDictBase) -> torch.Tensor:
        return self.risk_fn(tensordict)

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        risk = self.risk(tensordict)
        tensordict.set("risk", risk)
        tensordict.set("expert_mode", risk.double() > self.chi)
        return tensordict

    def calibrate(self, tensordict: TensorDictBase) -> float:
        """Set χ from the risk of the training states in ``tensordict`` (already through the policy heads)."""
        chi = self.rule(self.risk(tensordict))
        self.chi.fill_(chi)
        return chi


class ConstantGate(TensorDictModuleBase):
    """Expert always (demonstrations) or never (robot alone) in control."""

    def __init__(self, expert: bool, batch_key: str = "observation") -> None:
        super().__init__()
        self.in_keys = [batch_key]
        self.out_keys = ["expert_mode"]
        self.expert = bool(expert)
        self.batch_key = batch_key

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        ref = tensordict.get(self.batch_key)
        tensordict.set(
            "expert_mode", torch.full((*ref.shape[:-1], 1), self.expert, dtype=torch.bool, device=ref.device)
        )
        return tensordict
