"""DAgger as Ross et al. (2011) wrote it: roll out the mixture ``π_k = β_k π* + (1 − β_k) π̂_k`` and label
*every* visited state with the expert's action.

At every step of iteration ``k`` each robot executes the expert's action with probability ``β_k`` and
the learner's otherwise (a coin per robot per step, as imitation's ``InteractiveTrajectoryCollector``);
whoever drives, the expert's action for the state enters D (Algorithm 3 of Ross et al.: "collect
dataset D_i = {(s, π*(s))} of visited states by π_i"). ``β_k`` comes from ``method.beta_schedule``
(:mod:`dpiil_rl.modules.beta_schedule`; default ``β_k = 0.5^k``).

Effort: every step is an expert label (``expert_steps`` = the round's steps, so the quota of N
expert pairs is N visited states), the expert drives a share ``β_k`` of them (``expert_control_steps``)
and is queried at all of them (``expert_queries``). The paper's ``dagger`` (random take-overs whose
pairs alone are kept) is :mod:`dpiil_rl.methods.dagger`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Callable

import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase

from dpiil_rl.collectors.expert_switch import LABEL_REQUEST_KEY
from dpiil_rl.methods.base import Method

if TYPE_CHECKING:
    from torchrl.envs import EnvBase

    from dpiil_rl.experts.base import ExpertSource

BetaSchedule = Callable[[int], float]


class BetaMixtureGate(TensorDictModuleBase):
    """``expert_mode`` with probability ``β_k`` per robot and step; a label requested at every state."""

    beta: torch.Tensor  # buffer (registered in __init__)

    def __init__(self, schedule: BetaSchedule, seed: int, batch_key: str = "observation") -> None:
        super().__init__()
        self.in_keys = [batch_key]
        self.out_keys = ["expert_mode", LABEL_REQUEST_KEY]
        self.batch_key = batch_key
        self.schedule = schedule
        self.generator = torch.Generator().manual_seed(int(seed))
        self.register_buffer("beta", torch.tensor(1.0, dtype=torch.float64))  # β of the round in progress

    def start_round(self, iteration: int, phase: str) -> None:
        """Called by the collector as a round starts: ``β`` of iteration ``iteration``."""
        del phase
        self.beta.fill_(float(self.schedule(int(iteration))))

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        ref = tensordict.get(self.batch_key)
        shape = (*ref.shape[:-1], 1)
        u = torch.rand(shape, generator=self.generator, dtype=torch.float64)
        tensordict.set("expert_mode", (u < self.beta).to(ref.device))
        tensordict.set(LABEL_REQUEST_KEY, torch.ones(shape, dtype=torch.bool, device=ref.device))
        return tensordict

    def get_extra_state(self) -> Any:
        return {"generator": self.generator.get_state()}

    def set_extra_state(self, state: Any) -> None:
        self.generator.set_state(state["generator"])


class DAggerBeta(Method):
    def __init__(self, name: str, beta_schedule: BetaSchedule, **options: Any) -> None:
        super().__init__(name, **options)
        if not callable(beta_schedule):
            raise ValueError(f"method.beta_schedule = {beta_schedule!r}: expected a schedule with a '_target_'")
        self.beta_schedule = beta_schedule

    def make_gate(self, env: "EnvBase | None" = None, expert: "ExpertSource | None" = None) -> BetaMixtureGate:
        del env, expert
        seed = int(torch.randint(0, 2**31 - 1, (1,)))  # from the run's seeded global RNG (as DAgger's gate)
        return BetaMixtureGate(self.beta_schedule, seed)
