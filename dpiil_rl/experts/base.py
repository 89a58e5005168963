"""The interface every expert source implements (docs/design.md, "Architecture").

The collector only talks to this interface: it never knows whether a script, a person with a
mouse or a teleoperated UR5e produces the actions. Differences between sources are expressed as
capabilities (class attributes), never as type or name checks in the loop.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any

import torch
from tensordict import TensorDictBase
from torchrl.envs import EnvBase

from dpiil_rl.utils.connectable import Connectable
from dpiil_rl.utils.errors import DeviceUnavailable, SessionEnded  # noqa: F401  (raised here, defined at the bottom layer)


def check_person_env(env: EnvBase, source: str, action_dim: int | None = None, what: str = "") -> None:
    """A person-driven source (``expert=<source>``) drives one robot, and, when ``action_dim`` is given,
    commands that many action dimensions (``what`` names the action and its tasks in the error)."""
    if action_dim is not None:
        got = int(env.action_spec.shape[-1])
        if got != action_dim:
            raise ValueError(f"expert={source} commands {what}; env action has {got} dimensions, expected {action_dim}")
    n = int(env.batch_size[0])
    if n != 1:
        raise ValueError(f"expert={source}: protocol.interactive_envs = {n}: a person drives one robot, expected 1")


class ExpertSource(Connectable, ABC):
    """A demonstrator that maps the current step's tensordict to an action for every env in the batch."""

    #: True when the source can label any state, also while the robot is in control (scripted
    #: experts). A person only produces meaningful actions while in control.
    labels_every_step: bool = True
    #: True when the source acts again exactly as it did, given the same states and its saved state
    #: (scripted experts): a run paused inside an iteration then redoes that iteration from its start and
    #: ends as an uninterrupted run would. A person's episodes are kept instead (they cannot be redone).
    replayable: bool = False

    def __init__(self) -> None:
        self._connected = False

    # ---------------------------------------------------------------------------- acting
    @abstractmethod
    def get_action(self, tensordict: TensorDictBase) -> torch.Tensor:
        """The expert's action ``[*batch, action_dim]`` for the observation in ``tensordict``."""

    def observe(self, tensordict: TensorDictBase) -> None:
        """Called every step, whoever drives (after the gate): a person's window redraws and keeps real
        time here. Scripted sources need nothing."""

    #: after :meth:`get_action`, ``[*batch]`` bool: where the action is a demonstration. None = everywhere.
    #: A person who has not grabbed the robot yet holds it still; those steps are not demonstrations.
    labelled: torch.Tensor | None = None

    def wants_control(self, tensordict: TensorDictBase, in_control: torch.Tensor) -> torch.Tensor:
        """HG-DAgger: ``[*batch, 1]`` bool, True where the expert takes (or keeps) control.

        ``tensordict`` holds the state and the learner's proposed ``policy_action``; ``in_control``
        says where the expert already drives. Sources that cannot judge raise.
        """
        raise NotImplementedError(
            f"expert source {type(self).__name__} cannot decide when to take over; hg_dagger needs a source "
            "that can (expert=scripted, or a person: mouse, gamepad, keyboard, spacemouse, ur5e_teleop)"
        )

    def reset(self, mask: torch.Tensor) -> None:
        """Called when the envs where ``mask`` is True start a new episode."""

    # ---------------------------------------------------------------------------- resume
    def state_dict(self) -> dict[str, Any]:
        return {}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        del state
