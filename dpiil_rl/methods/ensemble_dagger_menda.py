"""EnsembleDAgger as Menda et al. (2019) wrote it: the novice acts only where it is both close to the expert
and sure of itself.

Their decision rule: the novice's action is executed iff ``‖π_N(s) − π_H(s)‖ ≤ τ`` (*discrepancy*) and
``σ²(s) ≤ χ`` (*doubt*, the ensemble's variance); otherwise the expert acts. The discrepancy needs the
expert's action at every step, also while the robot drives, so the expert is queried at every step:
that monitoring is counted (``expert_queries``). With a person, whose input means nothing while the
robot drives, the discrepancy can only be measured where they drive.

Here the discrepancy is measured in the action spec's units (each dim scaled to [-1, 1]), and τ and χ
are set after every refit by threshold rules on D (by default each flags the top 20% of D, the
paper's protocol for every risk-aware gate; Menda et al. set both by hand). The paper's
``ensemble_dagger`` (the doubt test alone) is :mod:`dpiil_rl.methods.ensemble_dagger`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase

from dpiil_rl.collectors.expert_switch import CONSULTED_KEY, QUERIED_KEY
from dpiil_rl.methods.base import Method
from dpiil_rl.modules.gate import ThresholdRule
from dpiil_rl.utils.specs import spec_bounds

if TYPE_CHECKING:
    from torchrl.envs import EnvBase

    from dpiil_rl.experts.base import ExpertSource


class DiscrepancyDoubtGate(TensorDictModuleBase):
    """``expert_mode = ‖(π(s) − π_H(s)) / scale‖ > τ  or  σ²(s) > χ``; writes ``risk = σ²`` (the doubt)."""

    act_scale: torch.Tensor  # buffers (registered in __init__)
    chi: torch.Tensor
    tau: torch.Tensor

    def __init__(
        self,
        expert: "ExpertSource",
        act_low: torch.Tensor,
        act_high: torch.Tensor,
        rule: ThresholdRule,
        discrepancy_rule: ThresholdRule,
    ) -> None:
        super().__init__()
        self.in_keys = ["observation", "policy_action", "action_var"]
        self.out_keys = ["risk", "expert_mode", "discrepancy", QUERIED_KEY, CONSULTED_KEY]
        self.expert = expert
        self.rule = rule
        self.discrepancy_rule = discrepancy_rule
        self.register_buffer("act_scale", ((act_high - act_low) / 2).float().clamp_min(1e-6))
        self.register_buffer("chi", torch.tensor(float("inf"), dtype=torch.float64))  # χ on σ²
        self.register_buffer("tau", torch.tensor(float("inf"), dtype=torch.float64))  # τ on the discrepancy

    def discrepancy(self, policy_action: torch.Tensor, expert_action: torch.Tensor) -> torch.Tensor:
        """``‖(π(s) − a_H) / scale‖`` ``[*batch, 1]``."""
        gap = (policy_action.float() - expert_action.float().to(policy_action.device)) / self.act_scale
        return gap.norm(dim=-1, keepdim=True)

    def risk(self, tensordict: TensorDictBase) -> torch.Tensor:
        return tensordict.get("action_var")

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        doubt = self.risk(tensordict)
        expert_action = self.expert.get_action(tensordict).to(doubt.device)
        tensordict.set(QUERIED_KEY, expert_action)  # the switch reuses it: the expert is asked once per step
        d = self.discrepancy(tensordict.get("policy_action"), expert_action)
        labelled = getattr(self.expert, "labelled", None)  # a person: their input is an action only where they drive
        if labelled is not None and labelled.numel() == d.numel():
            d = torch.where(labelled.reshape(d.shape).to(d.device), d, torch.zeros_like(d))
        shape = (*tensordict.get("observation").shape[:-1], 1)
        tensordict.set("risk", doubt)
        tensordict.set("discrepancy", d)
        tensordict.set("expert_mode", (d.double() > self.tau) | (doubt.double() > self.chi))
        tensordict.set(CONSULTED_KEY, torch.ones(shape, dtype=torch.bool, device=doubt.device))
        return tensordict

    def calibrate(self, tensordict: TensorDictBase) -> dict[str, float]:
        """χ from D's σ², τ from D's discrepancies between the refitted policy and the expert's labels."""
        doubt = tensordict.get("action_var")
        d = self.discrepancy(tensordict.get("policy_action"), tensordict.get("expert_action"))
        self.chi.fill_(self.rule(doubt))
        self.tau.fill_(self.discrepancy_rule(d))
        flagged = (d.double() > self.tau) | (doubt.double() > self.chi)
        return {
            "chi": float(self.chi),
            "menda/tau": float(self.tau),
            "train/flagged_fraction": float(flagged.float().mean()),
        }


class EnsembleDAggerMenda(Method):
    def __init__(
        self, name: str, threshold: ThresholdRule, discrepancy_threshold: ThresholdRule, **options: Any
    ) -> None:
        super().__init__(name, **options)
        for key, rule in (("threshold", threshold), ("discrepancy_threshold", discrepancy_threshold)):
            if not callable(rule):
                raise ValueError(f"method.{key} = {rule!r}: expected a threshold rule with a '_target_'")
        self.threshold = threshold
        self.discrepancy_threshold = discrepancy_threshold

    def make_gate(self, env: "EnvBase | None" = None, expert: "ExpertSource | None" = None) -> DiscrepancyDoubtGate:
        if env is None or expert is None:
            raise ValueError(
                "method=ensemble_dagger_menda needs the env (action scale) and the expert source "
                "(the discrepancy test asks the expert at every step)"
            )
        act_low, act_high = spec_bounds(env.action_spec)
        return DiscrepancyDoubtGate(expert, act_low, act_high, self.threshold, self.discrepancy_threshold)
