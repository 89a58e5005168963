"""Start a run the way ``dpiil-train`` does — wipe it (``overwrite``), skip it (finished), resume it
(checkpoint) or begin it — alone or with other seeds batched in one process (:mod:`.lockstep`)."""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any, Callable, Sequence

from omegaconf import DictConfig

from dpiil_rl.records.run_lock import hold_run_dir
from dpiil_rl.training.factory import build_trainer, run_status
from dpiil_rl.training.final_evaluation import final_evaluation
from dpiil_rl.training.interactive_trainer import InteractiveTrainer
from dpiil_rl.training.lockstep import train_lockstep


def prepare_run(cfg: DictConfig, run_dir: str | Path) -> InteractiveTrainer | None:
    """The trainer of the run in ``run_dir`` (resumed if it has a checkpoint), or None if it is finished."""
    run_dir = Path(run_dir)
    hold_run_dir(run_dir)  # before anything is wiped, skipped or resumed: one process per run
    if cfg.overwrite and run_dir.is_dir():
        for child in run_dir.iterdir():
            if child.name != ".hydra":
                shutil.rmtree(child) if child.is_dir() else child.unlink()
    status = run_status(run_dir)
    if status == "finished":
        print(f"[dpiil_rl] {run_dir} is already finished (summary.json exists); pass overwrite=true to run it again.")
        return None
    if status == "resumable":
        print(f"[dpiil_rl] resuming {run_dir} from its latest checkpoint")
    return build_trainer(cfg, run_dir)


def run_batched(
    runs: Sequence[tuple[DictConfig, Path]], on_finished: Callable[[Path], None] | None = None
) -> list[Path]:
    """Train the unfinished runs of ``runs`` (each ``(config, run directory)``) in one process, their refits
    batched; returns the directories of the runs that were trained. ``on_finished`` is called with each
    run's directory as it ends (also for runs found finished), after its final evaluation
    (:func:`~.final_evaluation.final_evaluation`)."""
    trainers, dirs = [], []
    cfg_of: dict[Path, DictConfig] = {}
    for cfg, run_dir in runs:
        trainer = prepare_run(cfg, run_dir)
        if trainer is None:
            final_evaluation(cfg, run_dir)
            if on_finished is not None:
                on_finished(Path(run_dir))
            continue
        cfg_of[Path(run_dir)] = cfg
        trainers.append(trainer)
        dirs.append(Path(run_dir))

    def finished(trainer: InteractiveTrainer, summary: dict[str, Any]) -> None:
        del summary
        trainer.logger.close()
        final_evaluation(cfg_of[Path(trainer.run_dir)], trainer.run_dir)
        if on_finished is not None:
            on_finished(trainer.run_dir)

    try:
        train_lockstep(trainers, on_finished=finished)
    finally:
        for trainer in trainers:
            trainer.logger.close()
    return dirs
