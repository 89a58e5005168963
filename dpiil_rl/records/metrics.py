"""Metrics and summaries as pure functions of ``episodes.jsonl`` rows (DESIGN section 5)."""

from __future__ import annotations

from typing import Any, Sequence

Row = dict[str, Any]
LABELLED_PHASES = ("demo", "interactive")  # phases whose expert frames enter the dataset


def _rate(rows: Sequence[Row], key: str) -> float | None:
    return sum(bool(r[key]) for r in rows) / len(rows) if rows else None


def iteration_metrics(episodes: Sequence[Row], iteration: int) -> Row:
    """The contract fields of ``metrics.jsonl`` for iteration ``iteration``."""
    interactive = [r for r in episodes if r["phase"] == "interactive" and r["iteration"] == iteration]
    evaluation = [r for r in episodes if r["phase"] == "eval" and r["iteration"] == iteration]
    labelled = [r for r in episodes if r["phase"] in LABELLED_PHASES and r["iteration"] <= iteration]
    this_round = [r for r in episodes if r["phase"] in LABELLED_PHASES and r["iteration"] == iteration]
    return {
        "iteration": int(iteration),
        "expert_actions": sum(int(r["expert_steps"]) for r in labelled),
        "interactive_success": _rate(interactive, "success"),
        "autonomous_success": _rate(evaluation, "success"),
        "interventions": sum(int(r["interventions"]) for r in interactive),
        "collisions": sum(bool(r["collision"]) for r in interactive),
        "episodes": len(this_round),
        "new_expert_actions": sum(int(r["expert_steps"]) for r in this_round),
        "eval_episodes": len(evaluation),
        "eval_collisions": sum(bool(r["collision"]) for r in evaluation),
    }


def run_summary(episodes: Sequence[Row]) -> Row:
    """Final numbers of a run: interactive success over all interactive episodes, last evaluation."""
    interactive = [r for r in episodes if r["phase"] == "interactive"]
    evals = [r for r in episodes if r["phase"] == "eval"]
    last = max((r["iteration"] for r in evals), default=None)
    final_eval = [r for r in evals if r["iteration"] == last]
    return {
        "interactive_success": _rate(interactive, "success"),
        "autonomous_success": _rate(final_eval, "success"),
        "expert_actions": sum(int(r["expert_steps"]) for r in episodes if r["phase"] in LABELLED_PHASES),
        "interventions": sum(int(r["interventions"]) for r in interactive),
        "collisions": sum(bool(r["collision"]) for r in interactive),
        "interactive_episodes": len(interactive),
        "final_iteration": last,
    }
