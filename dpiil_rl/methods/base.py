"""What a method is: the gate that decides when the expert acts (docs/design.md, "Methods").

Every method runs the same loop and the same collector. A method module subclasses :class:`Method`
(or :class:`RiskGatedMethod` when its gate thresholds a risk score) and is selected by
``configs/method/<name>.yaml`` through ``_target_``; nothing else names it.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import TYPE_CHECKING, Any, Mapping, Sequence

import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase

from dpiil_rl.methods.frontier_knob import FrontierKnob
from dpiil_rl.modules.gate import RiskGate, ThresholdRule

if TYPE_CHECKING:
    from torchrl.envs import EnvBase

    from dpiil_rl.experts.base import ExpertSource


class Method(ABC):
    """A method of the DAgger family, defined by its gate."""

    #: False for methods that never hand control over during training (behaviour cloning).
    interactive: bool = True
    #: True for methods that learn from every transition the robot and expert executed (a critic):
    #: the loop then keeps an ``experience`` buffer of (s, a, s', success, done) beside the dataset.
    needs_experience: bool = False

    def __init__(self, name: str, frontier: Mapping[str, Any] | None = None, **options: Any) -> None:
        self.name = str(name)
        if options:
            raise ValueError(f"method.{next(iter(options))}: unknown option for method {self.name!r}")
        #: the unit-free knob ``make frontier`` sweeps for this method (None: not on the frontier)
        self.frontier = FrontierKnob.from_config(frontier, self.name) if frontier is not None else None

    @abstractmethod
    def make_gate(self, env: "EnvBase | None" = None, expert: "ExpertSource | None" = None) -> TensorDictModuleBase:
        """The gate module writing ``expert_mode`` (and, if it has one, ``risk``).

        ``env`` gives the specs for gates with their own networks; ``expert`` is the source in the
        loop, for gates that consult it (an HG-DAgger expert decides when it takes over).
        """

    #: share of D's episodes held out of every policy refit for the gate's own model (SafeDAgger's classifier
    #: is fitted where the policy was not); 0 = the policy is fitted on all of D
    heldout_fraction: float = 0.0

    @property
    def uses_speed_head(self) -> bool:
        """Whether the gate reads the speed head (DPIIL). Others fit it once, on the demos, for the maps."""
        return False

    def extra_hooks(self) -> list[Any]:
        """Hooks this method adds to the training loop (e.g. a critic refit). None by default."""
        return []

    def __repr__(self) -> str:
        return f"{type(self).__name__}(name={self.name!r})"


class RiskGatedMethod(Method):
    """Expert mode iff ``risk(s) > χ``; χ from the method's threshold rule (quantile or fixed)."""

    #: keys the risk reads from the tensordict (written by the actor / speed head)
    risk_keys: Sequence[str] = ("action_var",)

    def __init__(self, name: str, threshold: ThresholdRule, **options: Any) -> None:
        super().__init__(name, **options)
        if not callable(threshold):
            raise ValueError(f"method.threshold = {threshold!r}: expected a threshold rule with a '_target_'")
        self.threshold = threshold

    @property
    def uses_speed_head(self) -> bool:
        return any(str(k).startswith("speed") for k in self.risk_keys)

    @abstractmethod
    def risk(self, tensordict: TensorDictBase) -> torch.Tensor:
        """Risk ``[*batch, 1]`` of the states in ``tensordict``."""

    def make_gate(self, env: "EnvBase | None" = None, expert: "ExpertSource | None" = None) -> RiskGate:
        del env, expert
        return RiskGate(self.risk, self.risk_keys, self.threshold)
