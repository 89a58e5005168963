"""Refit the ensemble actor and the speed head on the aggregate dataset D (Algorithm 1, line 6)."""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

from dpiil_rl.data.buffer import buffer_contents
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
        data = buffer_contents(trainer.buffer)
        actor_losses = trainer.actor.fit(data["observation"], data["expert_action"], self.actor_fit, trainer.generator)
        tail = max(1, len(actor_losses) // 20)
        out = {"dataset_size": int(data.shape[0]), "train/actor_mse": sum(actor_losses[-tail:]) / tail}
        # the speed head is refitted for methods whose gate reads it; the others fit it once, on the
        # initial demos (every run's precision map after k = 0), and save the refits
        if trainer.method.uses_speed_head or trainer.iteration == 0:
            speed_losses = trainer.speed_head.fit(data["observation"], data["speed"], self.speed_fit, trainer.generator)
            out["train/speed_nll"] = sum(speed_losses[-tail:]) / tail
        out["time/refit_s"] = time.perf_counter() - t0
        return out
