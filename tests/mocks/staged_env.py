"""Test-only multi-stage env: a point on a line whose ``stage`` follows a fixed per-step schedule."""

from __future__ import annotations

from typing import Any, Sequence

import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.envs import EnvBase

from dpiil_rl.envs.task_specs import reset_frame, reset_mask, set_task_specs


class StagedEnv(EnvBase):
    """``stage`` at step t is ``schedule[t - 1]``; env i's episode times out after ``lengths[i]`` steps
    (default ``len(schedule)`` for every env)."""

    # a class constant over EnvBase's read-only property, as TorchRL's own envs declare it
    batch_locked = True  # pyright: ignore[reportAssignmentType]
    position_key = "observation"

    def __init__(
        self, schedule: Sequence[int], stages: Sequence[str], num_envs: int = 1, lengths: Sequence[int] | None = None
    ) -> None:
        super().__init__(batch_size=torch.Size([num_envs]))
        self.schedule = torch.tensor(list(schedule), dtype=torch.int64)
        self.lengths = torch.tensor(list(lengths) if lengths is not None else [len(schedule)] * num_envs).reshape(
            num_envs, 1
        )
        set_task_specs(
            self,
            {"observation": (torch.full((2,), -10.0), torch.full((2,), 10.0))},
            len(schedule),
            ("success",),
            action=(-torch.ones(2), torch.ones(2)),
            stages=stages,
        )
        self._pos = torch.zeros(num_envs, 2)
        self._steps = torch.zeros(num_envs, 1, dtype=torch.int64)

    def _reset(self, tensordict: TensorDictBase | None, **kwargs: Any) -> TensorDictBase:
        mask = reset_mask(self, tensordict)
        self._pos[mask] = 0.0
        self._steps[mask] = 0
        return reset_frame(self, {"observation": self._pos}, self._steps)

    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        self._pos = self._pos + tensordict.get("action")
        self._steps = self._steps + 1
        done = self._steps >= self.lengths
        false = torch.zeros_like(done)
        return TensorDict(
            {
                "observation": self._pos.clone(),
                "step_count": self._steps.clone(),
                "success": false.clone(),
                "stage": self.schedule[(self._steps - 1).clamp_max(len(self.schedule) - 1)],
                "reward": torch.zeros(done.shape),
                "done": done,
                "terminated": false.clone(),
                "truncated": done.clone(),
            },
            batch_size=self.batch_size,
        )

    def _set_seed(self, seed: int | None) -> None:
        pass
