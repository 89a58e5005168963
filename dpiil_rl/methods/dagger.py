"""DAgger as the paper's "conventional IIL that randomly requests intervention" (Ross et al. 2011).

The expert takes over at random, blind to risk, in segments: each step an auto-mode env hands
control to the expert with probability ``p_on`` and an expert segment ends with probability
``1 / mean_segment_steps``. The stationary share of expert-controlled steps is then
``p_on / (p_on + 1/L)``; ``p_on`` is set so that it equals ``expert_share`` (default 20%, the share
the risk-gated methods flag). ``mean_segment_steps = 1`` is a per-step coin flip.

The segments are this library's choice, not the paper's: the paper says only that DAgger "randomly
requests intervention". The default ``mean_segment_steps = 10`` gives a person take-overs long enough
to act on; ``configs/method/dagger_1step.yaml`` (``method=dagger_1step``) is the per-step variant,
and studies report both. Unlike Ross et al.'s DAgger only the expert's own steps are kept; the
β-mixture that labels every visited state is :mod:`dpiil_rl.methods.dagger_beta`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import torch
from tensordict import TensorDictBase

from dpiil_rl.methods.base import Method
from dpiil_rl.modules.switching_gate import SwitchingGate

if TYPE_CHECKING:
    from torchrl.envs import EnvBase

    from dpiil_rl.experts.base import ExpertSource


class RandomSegmentGate(SwitchingGate):
    """Two-state Markov chain per env: auto → expert with ``p_on``, expert → auto with ``p_off``."""

    def __init__(self, p_on: float, p_off: float, seed: int) -> None:
        super().__init__(in_keys=["observation"])
        self.p_on, self.p_off = float(p_on), float(p_off)
        self.generator = torch.Generator().manual_seed(int(seed))

    def decide(self, tensordict: TensorDictBase, previous: torch.Tensor) -> torch.Tensor:
        u = torch.rand(previous.shape, generator=self.generator).to(previous.device)
        return torch.where(previous, u >= self.p_off, u < self.p_on)

    def get_extra_state(self) -> Any:
        return {"generator": self.generator.get_state()}

    def set_extra_state(self, state: Any) -> None:
        self.generator.set_state(state["generator"])


class DAgger(Method):
    def __init__(self, name: str, expert_share: float = 0.2, mean_segment_steps: float = 10.0, **options: Any) -> None:
        super().__init__(name, **options)
        if not 0.0 < float(expert_share) < 1.0:
            raise ValueError(f"method.expert_share = {expert_share}: expected a fraction strictly between 0 and 1")
        if not float(mean_segment_steps) >= 1.0:
            raise ValueError(f"method.mean_segment_steps = {mean_segment_steps}: expected a number of steps >= 1")
        self.expert_share = float(expert_share)
        self.mean_segment_steps = float(mean_segment_steps)

    @property
    def p_off(self) -> float:
        return 1.0 / self.mean_segment_steps

    @property
    def p_on(self) -> float:
        return min(1.0, self.expert_share / (1.0 - self.expert_share) * self.p_off)

    def make_gate(self, env: "EnvBase | None" = None, expert: "ExpertSource | None" = None) -> RandomSegmentGate:
        del env, expert
        seed = int(torch.randint(0, 2**31 - 1, (1,)))  # from the run's seeded global RNG
        return RandomSegmentGate(self.p_on, self.p_off, seed)
