"""The keys a dashboard shows a run's ``metrics.jsonl`` rows under (``interaction/…``, ``eval/…``, ``effort/…``,
``train/…``): the same for a live run and for finished runs replayed from their records."""

from __future__ import annotations

from typing import Any

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
