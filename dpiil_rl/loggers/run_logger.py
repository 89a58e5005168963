"""One small interface over TorchRL's loggers: scalars, images, close.

The run-directory files (``metrics.jsonl`` ...) are always written; these loggers are the
dashboards on top. Factories are the ``_target_`` of ``configs/logger/*.yaml``.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from torchrl.record.loggers import CSVLogger, Logger


class RunLogger:
    """Forwards to a TorchRL :class:`~torchrl.record.loggers.Logger` (or nothing)."""

    def __init__(self, logger: Logger | None = None) -> None:
        self.logger = logger

    def log_metrics(self, metrics: dict[str, Any], step: int) -> None:
        if self.logger is None:
            return
        for name, value in metrics.items():
            if isinstance(value, (int, float)) and not isinstance(value, bool):
                self.logger.log_scalar(name, float(value), step=step)

    def log_image(self, name: str, path: str | Path, step: int | None = None) -> None:
        del name, path, step

    def log_table(self, name: str, rows: list[dict[str, Any]]) -> None:
        """A table (one dict per row, same keys); dashboards that have tables show it, others skip it."""
        del name, rows

    def log_summary(self, values: dict[str, Any]) -> None:
        """The run's final numbers (the dashboard's run summary)."""
        del values

    def close(self) -> None:
        pass


class WandbRunLogger(RunLogger):
    """wandb through TorchRL's ``WandbLogger``; offline by default: no login, no network."""

    def log_image(self, name: str, path: str | Path, step: int | None = None) -> None:
        import wandb

        self.logger.experiment.log({name: wandb.Image(str(path))})  # type: ignore[union-attr]

    def log_table(self, name: str, rows: list[dict[str, Any]]) -> None:
        import wandb

        if not rows:
            return
        columns = list(rows[0])
        data = [[_cell(row.get(c)) for c in columns] for row in rows]
        self.logger.experiment.log({name: wandb.Table(columns=columns, data=data)})  # type: ignore[union-attr]

    def log_summary(self, values: dict[str, Any]) -> None:
        self.logger.experiment.summary.update({k: v for k, v in values.items() if v is not None})  # type: ignore[union-attr]

    def close(self) -> None:
        self.logger.experiment.finish()  # type: ignore[union-attr]


def _cell(value: Any) -> Any:
    """Table cells: lists (such as an episode's start position) become text."""
    return (
        ", ".join(f"{v:g}" if isinstance(v, float) else str(v) for v in value)
        if isinstance(value, (list, tuple))
        else value
    )


def run_display_name(env: str, run_name: str, seed: int) -> str:
    """A run's name on every dashboard: ``<env>-<run name>-seed<seed>``."""
    return f"{env}-{run_name}-seed{seed}"


def make_wandb_logger(
    run_dir: str,
    exp_name: str,
    group: str,
    job_type: str,
    run_config: dict[str, Any],
    project: str = "dpiil_rl",
    mode: str = "offline",
) -> RunLogger:
    if mode not in ("offline", "online", "disabled"):
        raise ValueError(f"logger.mode = {mode!r}: expected 'offline', 'online' or 'disabled'")
    os.environ.setdefault("WANDB_SILENT", "true")
    if mode != "online":
        os.environ["WANDB_MODE"] = mode
    from torchrl.record.loggers import WandbLogger

    logger = WandbLogger(
        exp_name,
        offline=mode != "online",
        save_dir=run_dir,
        project=project,
        group=group,
        job_type=job_type,
        config=run_config,
        log_env_packages=False,
        reinit="create_new",  # several runs of a batch of seeds log side by side in one process
    )
    return WandbRunLogger(logger)


def make_csv_logger(run_dir: str, exp_name: str, group: str, job_type: str, run_config: dict[str, Any]) -> RunLogger:
    del group, job_type, run_config
    return RunLogger(CSVLogger(exp_name, log_dir=str(Path(run_dir) / "csv")))


def make_null_logger(run_dir: str, exp_name: str, group: str, job_type: str, run_config: dict[str, Any]) -> RunLogger:
    del run_dir, exp_name, group, job_type, run_config
    return RunLogger(None)
