"""Metrics and summaries as pure functions of ``episodes.jsonl`` rows (docs/design.md, "The run directory")."""

from __future__ import annotations

from typing import Any, Sequence

Row = dict[str, Any]
LABELLED_PHASES = ("demo", "interactive")  # phases whose expert frames enter the dataset


def _rate(rows: Sequence[Row], key: str) -> float | None:
    return sum(bool(r[key]) for r in rows) / len(rows) if rows else None


def _total(rows: Sequence[Row], key: str) -> int | None:
    """Sum of ``key`` over ``rows``; None when a row predates the field (records made before it existed)."""
    if any(key not in r for r in rows):
        return None
    return sum(int(r[key]) for r in rows)


def effort(interactive: Sequence[Row]) -> Row:
    """The expert's effort over interactive episodes: steps they drove (``expert_control_steps``) and their
    share of all interactive steps (``expert_share``), steps at which they had to act or judge, monitoring
    included (``expert_queries``, ``query_share``). None where the rows predate these fields."""
    steps = sum(int(r["length"]) for r in interactive)
    control, queries = _total(interactive, "expert_control_steps"), _total(interactive, "expert_queries")
    return {
        "interactive_steps": steps,
        "expert_control_steps": control,
        "expert_share": control / steps if control is not None and steps else None,
        "expert_queries": queries,
        "query_share": queries / steps if queries is not None and steps else None,
    }


def iteration_mean_success(interactive: Sequence[Row]) -> float | None:
    """Interactive success as the mean over iterations of each iteration's success rate: a round in
    which the robot crashed until the episode cap weighs as one iteration, not as hundreds of episodes."""
    rates = [
        _rate([r for r in interactive if r["iteration"] == k], "success")
        for k in sorted({r["iteration"] for r in interactive})
    ]
    values = [x for x in rates if x is not None]
    return sum(values) / len(values) if values else None


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
        **effort(interactive),
    }


def run_summary(episodes: Sequence[Row]) -> Row:
    """Final numbers of a run: interactive success over all interactive episodes, last evaluation."""
    interactive = [r for r in episodes if r["phase"] == "interactive"]
    evals = [r for r in episodes if r["phase"] == "eval"]
    last = max((r["iteration"] for r in evals), default=None)
    final_eval = [r for r in evals if r["iteration"] == last]
    return {
        "interactive_success": _rate(interactive, "success"),
        "interactive_success_iter_mean": iteration_mean_success(interactive),
        "autonomous_success": _rate(final_eval, "success"),
        "expert_actions": sum(int(r["expert_steps"]) for r in episodes if r["phase"] in LABELLED_PHASES),
        "interventions": sum(int(r["interventions"]) for r in interactive),
        "collisions": sum(bool(r["collision"]) for r in interactive),
        "interactive_episodes": len(interactive),
        "final_iteration": last,
        **effort(interactive),
        **rollouts(episodes),
    }


def rollouts(episodes: Sequence[Row]) -> Row:
    """Episodes of the robot alone *during* training (phase ``rollout``, e.g. ThriftyDAgger's critic rollouts):
    their number, successes and collisions; empty for methods without them."""
    rows = [r for r in episodes if r["phase"] == "rollout"]
    if not rows:
        return {}
    return {
        "rollout_episodes": len(rows),
        "rollout_success": _rate(rows, "success"),
        "rollout_collisions": sum(bool(r["collision"]) for r in rows),
    }
