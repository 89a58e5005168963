"""Evaluate the robot alone (no expert) on a batch of episodes after every iteration."""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

import torch
from tensordict.nn import TensorDictSequential

from dpiil_rl.collectors.expert_switch import ExpertSwitch
from dpiil_rl.collectors.intervention import InterventionCollector
from dpiil_rl.collectors.stop_rules import EpisodeBudget
from dpiil_rl.hooks.base import LoopHook
from dpiil_rl.modules.gate import ConstantGate

if TYPE_CHECKING:
    from dpiil_rl.training.interactive_trainer import InteractiveTrainer


def autonomous_policy(actor: torch.nn.Module) -> TensorDictSequential:
    """The learned policy acting alone: ensemble mean action, never the expert."""
    return TensorDictSequential([actor, ConstantGate(False), ExpertSwitch(None)])


class EvaluateHook(LoopHook):
    """Runs ``episodes`` autonomous episodes on ``collector``'s env, reseeded identically each time
    (common random start states across iterations), and records them as phase ``eval``.

    With ``every = n > 1`` it evaluates only at iterations k = 0, n, 2n, ... and always at the last
    one (``final_iteration``): long tasks can spend their time on the final measurement.
    """

    def __init__(
        self,
        collector: InterventionCollector,
        episodes: int,
        seed: int,
        every: int = 1,
        final_iteration: int | None = None,
    ) -> None:
        if int(every) < 1:
            raise ValueError(f"protocol.eval_every = {every}: expected an iteration interval >= 1")
        self.collector = collector
        self.episodes = int(episodes)
        self.seed = int(seed)
        self.every = int(every)
        self.final_iteration = final_iteration

    def __call__(self, trainer: "InteractiveTrainer") -> dict[str, Any]:
        k = trainer.iteration
        if k % self.every != 0 and k != self.final_iteration:
            return {}
        t0 = time.perf_counter()
        self.collector.env.set_seed(self.seed)
        policy = autonomous_policy(trainer.actor)
        with torch.no_grad():
            for episode in self.collector.rollout(
                EpisodeBudget(self.episodes), "eval", trainer.iteration, policy=policy
            ):
                trainer.record_episode(episode)
        return {"time/eval_s": time.perf_counter() - t0}
