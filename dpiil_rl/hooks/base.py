"""Base class of the loop's hooks (TorchRL's ``TrainerHookBase`` contract).

A hook is called with the trainer at its stage (``post_iteration`` after every collection round,
``post_train`` once at the end) and returns metrics to add to the iteration's row.
"""

from __future__ import annotations

from abc import abstractmethod
from typing import TYPE_CHECKING, Any

from torchrl.trainers import TrainerHookBase

if TYPE_CHECKING:
    from dpiil_rl.training.interactive_trainer import InteractiveTrainer


class LoopHook(TrainerHookBase):
    stage: str = "post_iteration"

    def register(self, trainer: "InteractiveTrainer", name: str) -> None:  # type: ignore[override]
        trainer.register_op(self.stage, self, name)

    @abstractmethod
    def __call__(self, trainer: "InteractiveTrainer") -> dict[str, Any]:
        """Run at the hook's stage; return metrics (namespaced ``train/``, ``time/`` ...) or ``{}``."""

    def state_dict(self) -> dict[str, Any]:
        return {}

    def load_state_dict(self, state_dict: dict[str, Any]) -> None:
        del state_dict
