"""Recalibrate χ on the training data after every refit (top 20% of risk by default)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import torch
from tensordict import TensorDict

from dpiil_rl.data.buffer import buffer_contents
from dpiil_rl.hooks.base import LoopHook

if TYPE_CHECKING:
    from dpiil_rl.training.interactive_trainer import InteractiveTrainer


class CalibrateThresholdHook(LoopHook):
    def __call__(self, trainer: "InteractiveTrainer") -> dict[str, Any]:
        gate = trainer.gate
        if not hasattr(gate, "calibrate"):
            return {}
        data = buffer_contents(trainer.buffer)
        td = TensorDict({"observation": data["observation"]}, batch_size=data.shape)
        with torch.no_grad():
            td = trainer.speed_head(trainer.actor(td))
            chi = gate.calibrate(td)
            flagged = float((gate.risk(td).double() > gate.chi).float().mean())
        return {"chi": chi, "train/flagged_fraction": flagged}
