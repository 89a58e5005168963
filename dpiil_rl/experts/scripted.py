"""``expert=scripted``: the task's algorithmic careful person as an expert source.

The task's config carries its scripted policy (``env.expert`` with a ``_target_``), so adding a
task never touches this file: the source builds whatever policy the env names, against the env's
geometry, and draws its noise from its own seeded generator (saved for resume).
"""

from __future__ import annotations

from typing import Any, Callable

import torch
from hydra.utils import get_object
from tensordict import TensorDictBase
from torchrl.envs import EnvBase

from dpiil_rl.experts.base import ExpertSource


def build_scripted_policy(env: EnvBase) -> Callable[[torch.Tensor, torch.Generator], torch.Tensor]:
    """Instantiate the scripted policy described by ``env.expert_config`` for this env's geometry."""
    spec = dict(getattr(env, "expert_config", None) or {})
    if "_target_" not in spec:
        raise ValueError(
            f"env {type(env).__name__} has no scripted expert: expected an 'expert' block with a '_target_' "
            "in its env config"
        )
    cls = get_object(spec.pop("_target_"))
    return cls(geometry=env.geometry, **spec)


class ScriptedExpert(ExpertSource):
    """Scripted, state-feedback expert: it can label every state (DAgger-style relabelling)."""

    labels_every_step = True
    replayable = True  # a script: the same states and stream give the same actions

    def __init__(self, env: EnvBase, seed: int = 0, observation_key: str = "observation") -> None:
        super().__init__()
        self.policy = build_scripted_policy(env)
        self.observation_key = observation_key
        self.rng = torch.Generator().manual_seed(int(seed))

    def get_action(self, tensordict: TensorDictBase) -> torch.Tensor:
        obs = tensordict.get(self.observation_key)
        return self.policy(obs, self.rng).to(obs.device)

    def wants_control(self, tensordict: TensorDictBase, in_control: torch.Tensor) -> torch.Tensor:
        judge = getattr(self.policy, "wants_control", None)
        if judge is None:
            return super().wants_control(tensordict, in_control)
        obs = tensordict.get(self.observation_key)
        return judge(obs, tensordict.get("policy_action"), in_control).to(obs.device)

    def reset(self, mask: torch.Tensor) -> None:
        reset = getattr(self.policy, "reset", None)  # state-machine experts keep per-env memory
        if reset is not None:
            reset(mask)

    def state_dict(self) -> dict[str, Any]:
        return {"rng": self.rng.get_state()}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.rng.set_state(state["rng"])
