"""DPIIL_μ: ``Risk = σ²_θ(s) / μ_λ(s)``, precision from the mean of the demonstrator's speed."""

from __future__ import annotations

import torch
from tensordict import TensorDictBase

from dpiil_rl.methods.base import RiskGatedMethod


class DPIILMu(RiskGatedMethod):
    risk_keys = ("action_var", "speed_mu")

    def risk(self, tensordict: TensorDictBase) -> torch.Tensor:
        return tensordict.get("action_var") / tensordict.get("speed_mu")
