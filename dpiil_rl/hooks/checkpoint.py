"""Save everything needed to resume after a crash (models, χ, buffer, RNG, row counts): the loop's hook over
:mod:`dpiil_rl.records.checkpoints`."""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import TYPE_CHECKING, Any

from dpiil_rl.hooks.base import LoopHook
from dpiil_rl.records.checkpoints import PAUSE, checkpoint_dir, write_checkpoint

if TYPE_CHECKING:
    from dpiil_rl.training.interactive_trainer import InteractiveTrainer


class CheckpointHook(LoopHook):
    """Writes ``checkpoints/iter_XXX/{state.pt, buffer/[, experience/]}`` atomically, then points ``latest`` at it."""

    def __call__(self, trainer: "InteractiveTrainer") -> dict[str, Any]:
        write_checkpoint(trainer, checkpoint_dir(trainer.run_dir, trainer.iteration))
        if trainer.iteration >= 0:  # a finished iteration supersedes a pause inside it
            shutil.rmtree(Path(trainer.run_dir) / "checkpoints" / PAUSE, ignore_errors=True)
        return {}
