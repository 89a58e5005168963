"""The spec layout every task env of this package shares, and its partial-reset mask.

Each env is a batch of ``n`` robots with: bounded state keys (``observation`` and the position ``f_v``
reads), ``step_count`` up to the horizon, boolean per-step flags (``success``, ``collision``, ...), a
bounded action, a reward and ``done``/``terminated``/``truncated``. Only the bounds and the flag names
differ between tasks; they come from the task's geometry, never from a config's shape.
"""

from __future__ import annotations

from typing import Mapping, Sequence

import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.data import Bounded, Categorical, Composite, Unbounded
from torchrl.envs import EnvBase

Bounds = tuple[torch.Tensor, torch.Tensor]  # (low, high), each [dim] (or already [n, dim])


def set_task_specs(
    env: EnvBase, states: Mapping[str, Bounds], max_steps: int, flags: Sequence[str], action: Bounds
) -> None:
    """Give ``env`` (batch ``[n]``) its observation, action, reward and done specs."""
    n = env.batch_size[0]
    device = env.device

    def bounded(low: torch.Tensor, high: torch.Tensor) -> Bounded:
        low = torch.as_tensor(low, dtype=torch.float32, device=device)
        high = torch.as_tensor(high, dtype=torch.float32, device=device)
        dim = low.shape[-1]
        return Bounded(low=low.expand(n, dim), high=high.expand(n, dim), shape=(n, dim), device=device)

    flag = Categorical(2, shape=(n, 1), dtype=torch.bool, device=device)
    env.observation_spec = Composite(
        **{key: bounded(low, high) for key, (low, high) in states.items()},
        step_count=Bounded(low=0, high=int(max_steps), shape=(n, 1), dtype=torch.int64, device=device),
        **{name: flag.clone() for name in flags},
        shape=(n,),
        device=device,
    )
    env.action_spec = bounded(*action)
    env.reward_spec = Unbounded(shape=(n, 1), device=device)
    env.done_spec = Composite(done=flag.clone(), terminated=flag.clone(), truncated=flag.clone(), shape=(n,), device=device)


def reset_mask(env: EnvBase, tensordict: TensorDictBase | None) -> torch.Tensor:
    """Which of the ``n`` envs to reset: ``_reset`` of a partial reset, else all (``[n]`` bool, env's device)."""
    n = env.batch_size[0]
    if tensordict is not None and "_reset" in tensordict.keys():
        return tensordict.get("_reset").reshape(n).to(env.device)
    return torch.ones(n, dtype=torch.bool, device=env.device)


def reset_frame(env: EnvBase, states: Mapping[str, torch.Tensor], step_count: torch.Tensor) -> TensorDictBase:
    """The frame ``_reset`` returns: the state keys, ``step_count``, and every flag of the observation
    spec and ``done``/``terminated``/``truncated`` all false."""
    n = env.batch_size[0]
    false = torch.zeros(n, 1, dtype=torch.bool, device=env.device)
    flags = [key for key, spec in env.observation_spec.items() if spec.dtype == torch.bool]
    return TensorDict(
        {**{key: value.clone() for key, value in states.items()}, "step_count": step_count.clone(),
         **{name: false.clone() for name in (*flags, "done", "terminated", "truncated")}},
        batch_size=env.batch_size,
        device=env.device,
    )
