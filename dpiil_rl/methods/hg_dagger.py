"""HG-DAgger (Kelly et al. 2019): the expert decides when to take over and when to hand back.

The gate asks the expert source itself (:meth:`ExpertSource.wants_control`): a person presses a
take-over button; the scripted expert of a task grabs control when it sees a failure coming (the
learner's command would graze a wall, or points far off its own) and, being conservative, hands
back only in open space once the learner agrees with it — the paper's oracle. The expert watches
every step to decide, so every step is an expert query (``expert_queries``), whoever drives.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import torch
from tensordict import TensorDictBase

from dpiil_rl.collectors.expert_switch import CONSULTED_KEY
from dpiil_rl.methods.base import Method
from dpiil_rl.modules.switching_gate import SwitchingGate

if TYPE_CHECKING:
    from torchrl.envs import EnvBase

    from dpiil_rl.experts.base import ExpertSource


class ExpertJudgedGate(SwitchingGate):
    def __init__(self, expert: "ExpertSource") -> None:
        super().__init__(in_keys=["observation", "policy_action"])
        self.expert = expert

    def decide(self, tensordict: TensorDictBase, previous: torch.Tensor) -> torch.Tensor:
        # the expert watches every step to judge when to take over: monitoring, counted as a query
        tensordict.set(CONSULTED_KEY, torch.ones_like(previous, dtype=torch.bool))
        return self.expert.wants_control(tensordict, previous).reshape(previous.shape).to(previous.device)


class HGDAgger(Method):
    def make_gate(self, env: "EnvBase | None" = None, expert: "ExpertSource | None" = None) -> ExpertJudgedGate:
        if expert is None:
            raise ValueError(
                "method=hg_dagger needs an expert source in the loop: the expert decides when to take over"
            )
        return ExpertJudgedGate(expert)
