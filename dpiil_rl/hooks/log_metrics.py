"""Write the iteration's row to ``metrics.jsonl`` (from episode rows) and to the dashboard logger."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from dpiil_rl.hooks.base import LoopHook
from dpiil_rl.loggers.dashboard_keys import dashboard_row
from dpiil_rl.records.metrics import iteration_metrics

if TYPE_CHECKING:
    from dpiil_rl.training.interactive_trainer import InteractiveTrainer


class LogMetricsHook(LoopHook):
    def __call__(self, trainer: "InteractiveTrainer") -> dict[str, Any]:
        row = iteration_metrics(trainer.run_files.episodes, trainer.iteration)
        row.update(trainer.current_metrics)
        row["time/elapsed_s"] = trainer.elapsed()
        trainer.run_files.add_metrics(row)
        trainer.logger.log_metrics(dashboard_row(row), step=trainer.iteration)
        return {}
