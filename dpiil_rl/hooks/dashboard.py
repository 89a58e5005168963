"""At the end of a run: the episode table and the run's final numbers on the dashboard.

Every row of ``episodes.jsonl`` (phase, iteration, success, collision, length, expert steps,
interventions, start) becomes a row of the ``episodes`` table, so the dashboard can filter and
group episodes; the summary (``run_summary``) becomes the dashboard's run summary.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from dpiil_rl.hooks.base import LoopHook
from dpiil_rl.records.metrics import run_summary

if TYPE_CHECKING:
    from dpiil_rl.training.interactive_trainer import InteractiveTrainer


class DashboardHook(LoopHook):
    stage = "post_train"

    def __call__(self, trainer: "InteractiveTrainer") -> dict[str, Any]:
        trainer.logger.log_table("episodes", list(trainer.run_files.episodes))
        trainer.logger.log_summary({**trainer.info, **run_summary(trainer.run_files.episodes)})
        return {}
