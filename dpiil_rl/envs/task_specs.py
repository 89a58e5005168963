"""The spec layout every task env of this package shares, and its partial-reset mask.

Each env is a batch of ``n`` robots with: bounded state keys (``observation`` and the position ``f_v``
reads), ``step_count`` up to the horizon, boolean per-step flags (``success``, ``collision``, ...), a
bounded action, a reward and ``done``/``terminated``/``truncated``. A multi-stage task also writes the
``stage`` it is in (an index into the env's ``stage_names``, e.g. reach → grasped → lifted → at_peg →
threaded), so records can say how far a failed episode got. Only the bounds, the flag names and the
stages differ between tasks; they come from the task's geometry, never from a config's shape.
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.data import Bounded, Categorical, Composite, Unbounded
from torchrl.envs import EnvBase

Bounds = tuple[torch.Tensor, torch.Tensor]  # (low, high), each [dim] (or already [n, dim])


def set_task_specs(
    env: EnvBase,
    states: Mapping[str, Bounds],
    max_steps: int,
    flags: Sequence[str],
    action: Bounds,
    stages: Sequence[str] = (),
) -> None:
    """Give ``env`` (batch ``[n]``) its observation, action, reward and done specs.

    With ``stages`` (at least two names, in the order a successful episode passes them) the observation
    spec gets ``stage`` (int64 ``[n, 1]`` in ``[0, len(stages) - 1]``) and ``env.stage_names = tuple(stages)``.
    """
    n = env.batch_size[0]
    device = env.device

    def bounded(low: torch.Tensor, high: torch.Tensor) -> Bounded:
        low = torch.as_tensor(low, dtype=torch.float32, device=device)
        high = torch.as_tensor(high, dtype=torch.float32, device=device)
        dim = low.shape[-1]
        return Bounded(low=low.expand(n, dim), high=high.expand(n, dim), shape=torch.Size([n, dim]), device=device)

    stages = tuple(stages)
    if stages and (len(stages) < 2 or len(set(stages)) != len(stages)):
        raise ValueError(f"stages = {list(stages)}: expected at least two distinct stage names, in order")
    flag = Categorical(2, shape=torch.Size([n, 1]), dtype=torch.bool, device=device)
    stage: dict[str, Any] = (  # a keyword spec of Composite ("stage" is none of its own parameters)
        {"stage": Bounded(low=0, high=len(stages) - 1, shape=torch.Size([n, 1]), dtype=torch.int64, device=device)}
        if stages
        else {}
    )
    env.stage_names = stages
    env.observation_spec = Composite(
        **{key: bounded(low, high) for key, (low, high) in states.items()},
        step_count=Bounded(low=0, high=int(max_steps), shape=torch.Size([n, 1]), dtype=torch.int64, device=device),
        **{name: flag.clone() for name in flags},
        **stage,
        shape=(n,),
        device=device,
    )
    env.action_spec = bounded(*action)
    env.reward_spec = Unbounded(shape=torch.Size([n, 1]), device=device)
    env.done_spec = Composite(
        done=flag.clone(), terminated=flag.clone(), truncated=flag.clone(), shape=(n,), device=device
    )


def reset_mask(env: EnvBase, tensordict: TensorDictBase | None) -> torch.Tensor:
    """Which of the ``n`` envs to reset: ``_reset`` of a partial reset, else all (``[n]`` bool, env's device)."""
    n = env.batch_size[0]
    if tensordict is not None and "_reset" in tensordict.keys():
        return tensordict.get("_reset").reshape(n).to(env.device)
    return torch.ones(n, dtype=torch.bool, device=env.device)


def reset_frame(env: EnvBase, states: Mapping[str, torch.Tensor], step_count: torch.Tensor) -> TensorDictBase:
    """The frame ``_reset`` returns: the state keys, ``step_count``, every flag of the observation
    spec and ``done``/``terminated``/``truncated`` all false, and ``stage`` (if the task has stages) 0."""
    n = env.batch_size[0]
    false = torch.zeros(n, 1, dtype=torch.bool, device=env.device)
    flags = [key for key, spec in env.observation_spec.items() if spec.dtype == torch.bool]
    stage = (
        {"stage": torch.zeros(n, 1, dtype=torch.int64, device=env.device)}
        if "stage" in env.observation_spec.keys()
        else {}
    )
    return TensorDict(
        {
            **{key: value.clone() for key, value in states.items()},
            "step_count": step_count.clone(),
            **{name: false.clone() for name in (*flags, "done", "terminated", "truncated")},
            **stage,
        },
        batch_size=env.batch_size,
        device=env.device,
    )
