"""Recalibrate χ on the training data after every refit (top 20% of risk by default)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import torch
from tensordict import TensorDict

from dpiil_rl.data.buffer import training_data
from dpiil_rl.hooks.base import LoopHook

if TYPE_CHECKING:
    from dpiil_rl.training.interactive_trainer import InteractiveTrainer


class CalibrateThresholdHook(LoopHook):
    """Calls ``gate.calibrate(td)`` on the training states after the heads ran on them.

    ``td`` holds ``observation`` and ``expert_action`` of every frame of D plus the heads' outputs.
    A gate returns its χ (a float) or a dict of metrics (gates with several thresholds).
    """

    def __call__(self, trainer: "InteractiveTrainer") -> dict[str, Any]:
        gate: Any = trainer.gate  # duck-typed: calibrate, risk and chi where a gate has them
        if not hasattr(gate, "calibrate"):
            return {}
        data = training_data(trainer.buffer)
        td = TensorDict(
            {"observation": data["observation"], "expert_action": data["expert_action"]}, batch_size=data.shape
        )
        with torch.no_grad():
            td = trainer.speed_head(trainer.actor(td))
            out = gate.calibrate(td)
            if isinstance(out, dict):
                return dict(out)
            flagged = float((gate.risk(td).double() > gate.chi).float().mean())
        return {"chi": out, "train/flagged_fraction": flagged}
