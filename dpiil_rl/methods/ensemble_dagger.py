"""EnsembleDAgger (Menda et al. 2019): ``Risk = σ²_θ(s)``, the ensemble's disagreement alone.

As in the paper's comparison, only the policy-uncertainty test is used (no precision term): the
robot asks for help where its ensemble is unsure, wherever that is, narrow or open.
"""

from __future__ import annotations

import torch
from tensordict import TensorDictBase

from dpiil_rl.methods.base import RiskGatedMethod


class EnsembleDAgger(RiskGatedMethod):
    risk_keys = ("action_var",)

    def risk(self, tensordict: TensorDictBase) -> torch.Tensor:
        return tensordict.get("action_var")
