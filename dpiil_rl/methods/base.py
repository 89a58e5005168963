"""What a method is: the gate that decides when the expert acts (DESIGN section 2).

Every method runs the same loop and the same collector. A method module subclasses :class:`Method`
(or :class:`RiskGatedMethod` when its gate thresholds a risk score) and is selected by
``configs/method/<name>.yaml`` through ``_target_``; nothing else names it.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any, Sequence

import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase

from dpiil_rl.modules.gate import RiskGate, ThresholdRule


class Method(ABC):
    """A method of the DAgger family, defined by its gate."""

    #: False for methods that never hand control over during training (behaviour cloning).
    interactive: bool = True

    def __init__(self, name: str, **options: Any) -> None:
        self.name = str(name)
        if options:
            raise ValueError(f"method.{next(iter(options))}: unknown option for method {self.name!r}")

    @abstractmethod
    def make_gate(self) -> TensorDictModuleBase:
        """The gate module writing ``expert_mode`` (and, if it has one, ``risk``)."""

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

    @abstractmethod
    def risk(self, tensordict: TensorDictBase) -> torch.Tensor:
        """Risk ``[*batch, 1]`` of the states in ``tensordict``."""

    def make_gate(self) -> RiskGate:
        return RiskGate(self.risk, self.risk_keys, self.threshold)
