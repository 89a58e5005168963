"""Write the iteration's row to ``metrics.jsonl`` (from episode rows) and to the dashboard logger."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from dpiil_rl.hooks.base import LoopHook
from dpiil_rl.records.metrics import iteration_metrics

if TYPE_CHECKING:
    from dpiil_rl.training.interactive_trainer import InteractiveTrainer

# dashboard namespace of each contract field
_NAMESPACE = {
    "interactive_success": "interaction",
    "interventions": "interaction",
    "collisions": "interaction",
    "episodes": "interaction",
    "new_expert_actions": "interaction",
    "expert_actions": "interaction",
    "interactive_steps": "effort",
    "expert_control_steps": "effort",
    "expert_share": "effort",
    "expert_queries": "effort",
    "query_share": "effort",
    "chi": "train",
    "dataset_size": "train",
    "autonomous_success": "eval",
    "eval_episodes": "eval",
    "eval_collisions": "eval",
}


def dashboard_row(row: dict[str, Any]) -> dict[str, Any]:
    """A ``metrics.jsonl`` row as the dashboard's keys (``interaction/…``, ``eval/…``, ``train/…``; keys
    with a ``/`` as they are), without ``iteration`` (the dashboard's step)."""
    return {(k if "/" in k else f"{_NAMESPACE.get(k, 'train')}/{k}"): v for k, v in row.items() if k != "iteration"}


class LogMetricsHook(LoopHook):
    def __call__(self, trainer: "InteractiveTrainer") -> dict[str, Any]:
        row = iteration_metrics(trainer.run_files.episodes, trainer.iteration)
        row.update(trainer.current_metrics)
        row["time/elapsed_s"] = trainer.elapsed()
        trainer.run_files.add_metrics(row)
        trainer.logger.log_metrics(dashboard_row(row), step=trainer.iteration)
        return {}
