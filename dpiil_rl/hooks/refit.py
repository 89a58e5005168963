"""Refit the ensemble actor and the speed head on the aggregate dataset D (Algorithm 1, line 6)."""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

from dpiil_rl.data.buffer import training_data
from dpiil_rl.data.splits import heldout_episodes
from dpiil_rl.hooks.base import LoopHook
from dpiil_rl.modules.fitting import FitSettings

if TYPE_CHECKING:
    from dpiil_rl.training.interactive_trainer import InteractiveTrainer


class RefitHook(LoopHook):
    def __init__(self, actor_fit: FitSettings, speed_fit: FitSettings) -> None:
        self.actor_fit = actor_fit
        self.speed_fit = speed_fit

    def __call__(self, trainer: "InteractiveTrainer") -> dict[str, Any]:
        t0 = time.perf_counter()
        data = training_data(trainer.buffer)
        # a method whose gate has its own model holds some episodes out of the policy's fit for it
        heldout = heldout_episodes(data["episode"], trainer.method.heldout_fraction, trainer.generator)
        trainer.heldout = heldout
        policy_data = data[~heldout]
        actor_losses = trainer.actor.fit(policy_data["observation"], policy_data["expert_action"], self.actor_fit, trainer.generator)
        tail = max(1, len(actor_losses) // 20)
        out = {"dataset_size": int(data.shape[0]), "train/actor_mse": sum(actor_losses[-tail:]) / tail}
        if trainer.method.heldout_fraction:
            out["train/heldout_frames"] = int(heldout.sum())
        # the speed head is refitted for methods whose gate reads it; the others fit it once, on the
        # initial demos (every run's precision map after k = 0), and save the refits
        if trainer.method.uses_speed_head or trainer.iteration == 0:
            drove = data.get("expert_drove", None)  # the expert's own speeds only (not labels of robot-driven states)
            speeds = data if drove is None else data[drove.reshape(-1).bool()]
            speed_losses = trainer.speed_head.fit(speeds["observation"], speeds["speed"], self.speed_fit, trainer.generator)
            out["train/speed_nll"] = sum(speed_losses[-tail:]) / tail
        out["time/refit_s"] = time.perf_counter() - t0
        return out
