"""Evaluate the robot alone (no expert) on a batch of episodes after every iteration."""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

import torch
from tensordict.nn import TensorDictSequential

from dpiil_rl.collectors.intervention import InterventionCollector
from dpiil_rl.collectors.stop_rules import EpisodeBudget
from dpiil_rl.hooks.base import LoopHook
from dpiil_rl.modules.expert_switch import ExpertSwitch
from dpiil_rl.modules.gate import ConstantGate

if TYPE_CHECKING:
    from dpiil_rl.training.interactive_trainer import InteractiveTrainer


def autonomous_policy(actor: torch.nn.Module) -> TensorDictSequential:
    """The learned policy acting alone: ensemble mean action, never the expert."""
    return TensorDictSequential(actor, ConstantGate(False), ExpertSwitch(None))


class EvaluateHook(LoopHook):
    """Runs ``episodes`` autonomous episodes on ``collector``'s env, reseeded identically each time
    (common random start states across iterations), and records them as phase ``eval``."""

    def __init__(self, collector: InterventionCollector, episodes: int, seed: int) -> None:
        self.collector = collector
        self.episodes = int(episodes)
        self.seed = int(seed)

    def __call__(self, trainer: "InteractiveTrainer") -> dict[str, Any]:
        t0 = time.perf_counter()
        self.collector.env.set_seed(self.seed)
        policy = autonomous_policy(trainer.actor)
        with torch.no_grad():
            for episode in self.collector.rollout(EpisodeBudget(self.episodes), "eval", trainer.iteration, policy=policy):
                trainer.record_episode(episode)
        return {"time/eval_s": time.perf_counter() - t0}
