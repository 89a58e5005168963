"""Save everything needed to resume after a crash (models, χ, buffer, RNG, row counts): the loop's hook over
:mod:`dpiil_rl.records.checkpoints`."""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import TYPE_CHECKING, Any

from dpiil_rl.hooks.base import LoopHook
from dpiil_rl.records.checkpoints import PAUSE, checkpoint_dir, prune_checkpoints, write_checkpoint

if TYPE_CHECKING:
    from dpiil_rl.training.interactive_trainer import InteractiveTrainer


class CheckpointHook(LoopHook):
    """Writes ``checkpoints/iter_XXX/{state.pt, buffer/[, experience/]}`` atomically, then points ``latest`` at it.

    ``keep`` (the ``checkpoint_keep`` key): ``None`` keeps every iteration's checkpoint; ``n`` keeps
    iteration 0 and the newest ``n``, so a study of thousands of runs does not fill the disk (a run's
    checkpoints grow with its buffer, ≈ 50 MB over the aperture protocol's iterations)."""

    def __init__(self, keep: int | None = None) -> None:
        if keep is not None and (isinstance(keep, bool) or not isinstance(keep, int) or keep < 1):
            raise ValueError(f"checkpoint_keep = {keep!r}: expected null (keep all) or an integer >= 1")
        self.keep = keep

    def __call__(self, trainer: "InteractiveTrainer") -> dict[str, Any]:
        write_checkpoint(trainer, checkpoint_dir(trainer.run_dir, trainer.iteration))
        if trainer.iteration >= 0:  # a finished iteration supersedes a pause inside it
            shutil.rmtree(Path(trainer.run_dir) / "checkpoints" / PAUSE, ignore_errors=True)
        if self.keep is not None:
            prune_checkpoints(trainer.run_dir, self.keep)
        return {}
