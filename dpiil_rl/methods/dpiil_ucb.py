"""DPIIL_UCB (the paper's best): ``Risk = σ²_θ(s) / (μ_λ(s) + σ_λ(s))``, precision from the speed UCB."""

from __future__ import annotations

import torch
from tensordict import TensorDictBase

from dpiil_rl.methods.base import RiskGatedMethod


class DPIILUCB(RiskGatedMethod):
    risk_keys = ("action_var", "speed_mu", "speed_sigma")

    def risk(self, tensordict: TensorDictBase) -> torch.Tensor:
        precision = 1.0 / (tensordict.get("speed_mu") + tensordict.get("speed_sigma"))
        return precision * tensordict.get("action_var")
