"""Behaviour cloning: no interaction. The expert only demonstrates.

After the initial demonstrations, every iteration adds whole expert demonstrations until the
iteration's quota of expert pairs is met (the episode in progress finishes), so BC ends with
roughly as many expert actions as the interactive methods (paper section V-A). The robot never
acts during training; it is tested alone after every refit like every other method.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from dpiil_rl.methods.base import Method
from dpiil_rl.modules.gate import ConstantGate

if TYPE_CHECKING:
    from torchrl.envs import EnvBase

    from dpiil_rl.experts.base import ExpertSource


class BC(Method):
    interactive = False

    def make_gate(self, env: "EnvBase | None" = None, expert: "ExpertSource | None" = None) -> ConstantGate:
        del env, expert
        return ConstantGate(False)  # never used to collect: BC's rounds are expert demonstrations
