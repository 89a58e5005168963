"""Collapses: refits whose policy fails almost every test episode after the same run had mastered the task.

An evaluation *collapses* when its autonomous success is below ``low`` (10%) although an earlier
evaluation of the same run reached at least ``high`` (90%). Counted from the runs' ``eval`` rows of
``episodes.jsonl``, as every other number. The rate is over all evaluations of the runs (every
evaluation can collapse except a run's first), with the runs that collapsed at least once beside it.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass, field
from typing import Iterable, Sequence

from dpiil_rl.records.metrics import Row

LOW, HIGH = 0.10, 0.90  # a collapse: below LOW after an earlier evaluation at or above HIGH


def evaluation_curve(episodes: Sequence[Row]) -> list[tuple[int, float]]:
    """``(iteration, autonomous success)`` of every evaluation of a run, in iteration order."""
    by_iteration: dict[int, list[bool]] = defaultdict(list)
    for r in episodes:
        if r["phase"] == "eval":
            by_iteration[int(r["iteration"])].append(bool(r["success"]))
    return [(k, sum(v) / len(v)) for k, v in sorted(by_iteration.items())]


def collapsed_iterations(curve: Sequence[tuple[int, float]], low: float = LOW, high: float = HIGH) -> list[int]:
    """Iterations whose evaluation collapsed (below ``low`` after an earlier one at or above ``high``)."""
    out, mastered = [], False
    for k, success in curve:
        if mastered and success < low:
            out.append(k)
        mastered = mastered or success >= high
    return out


@dataclass
class CollapseCount:
    """Collapses of one group of runs (an env and method, say)."""

    runs: int = 0
    evaluations: int = 0
    collapses: int = 0
    collapsed_runs: list[str] = field(default_factory=list)  # "seed_<s> (k = 2, 4)"

    @property
    def rate(self) -> float | None:
        return self.collapses / self.evaluations if self.evaluations else None


def count_collapses(runs: Iterable[tuple[tuple[str, ...], str, Sequence[Row]]]) -> dict[tuple[str, ...], CollapseCount]:
    """``{group: CollapseCount}`` for ``(group, run label, episode rows)`` triples."""
    out: dict[tuple[str, ...], CollapseCount] = defaultdict(CollapseCount)
    for group, label, episodes in runs:
        curve = evaluation_curve(episodes)
        ks = collapsed_iterations(curve)
        c = out[group]
        c.runs += 1
        c.evaluations += len(curve)
        c.collapses += len(ks)
        if ks:
            c.collapsed_runs.append(f"{label} (k = {', '.join(str(k) for k in ks)})")
    return dict(out)


def total(counts: Iterable[CollapseCount]) -> CollapseCount:
    out = CollapseCount()
    for c in counts:
        out.runs += c.runs
        out.evaluations += c.evaluations
        out.collapses += c.collapses
        out.collapsed_runs += c.collapsed_runs
    return out
