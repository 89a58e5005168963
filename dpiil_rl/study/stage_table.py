"""How far episodes got on a multi-stage task: counts of the furthest stage each episode reached.

Multi-stage tasks (the ring: reach → grasped → lifted → at_peg → threaded) record in every row of
``episodes.jsonl`` the furthest ``stage`` and its ``stage_index`` in the task's order. Per (env, method)
this module pools the runs' episodes of one kind — the autonomous test episodes of each run's last
evaluation, or all interactive episodes — and counts them per stage, so a table can say *where* a
method's failures stop (never grasped, dropped on the way, at the peg but not threaded).
Runs recorded before stages existed have no ``stage`` and are left out (and counted as such). The
stages' order is the ``stages`` list of a run's ``summary.json``.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Any, Iterable, Iterator, Sequence

from dpiil_rl.study.study_runs import method_order

Row = dict[str, Any]

#: which episodes of a run a table counts
KINDS = ("final_eval", "interactive")


@dataclass
class StageCounts:
    """Episodes of one (env, method) per furthest stage, pooled over its runs."""

    env: str
    method: str
    runs: int = 0
    counts: Counter = field(default_factory=Counter)  # stage name -> episodes
    unstaged_runs: int = 0  # runs whose records have no stage (recorded before stages existed)

    @property
    def episodes(self) -> int:
        return sum(self.counts.values())


def episodes_of_kind(episodes: Sequence[Row], kind: str) -> list[Row]:
    """The rows of ``kind``: ``final_eval`` = the test episodes of the last evaluated iteration;
    ``interactive`` = every interactive episode."""
    if kind not in KINDS:
        raise ValueError(f"kind = {kind!r}: expected one of {list(KINDS)}")
    if kind == "interactive":
        return [r for r in episodes if r["phase"] == "interactive"]
    evals = [r for r in episodes if r["phase"] == "eval"]
    last = max((r["iteration"] for r in evals), default=None)
    return [r for r in evals if r["iteration"] == last]


def stage_order(rows: Iterable[Row], runs: Iterable[Any] = ()) -> list[str]:
    """Stage names in the task's order: the ``stages`` a run's ``summary.json`` lists (all of them), else
    those the rows reached, ordered by their recorded ``stage_index``."""
    for run in runs:
        names = (getattr(run, "recorded", None) or {}).get("stages")
        if names:
            return [str(n) for n in names]
    index: dict[str, int] = {}
    for r in rows:
        if "stage" in r:
            index.setdefault(str(r["stage"]), int(r["stage_index"]))
    return sorted(index, key=index.__getitem__)


def stage_counts(runs: Iterable[Any], kind: str = "final_eval") -> list[StageCounts]:
    """One :class:`StageCounts` per (env, run name) of ``runs`` (objects with ``env``, ``method``,
    ``episodes`` and, optionally, ``run_name``: a method's variants and knob values are rows of their own, not
    pooled with the method), in env then paper order."""
    groups: dict[tuple[str, str], StageCounts] = {}
    for run in runs:
        rows = episodes_of_kind(run.episodes, kind)
        name = getattr(run, "run_name", None) or run.method
        group = groups.setdefault((run.env, name), StageCounts(run.env, name))
        if not rows:  # e.g. no interactive episodes (BC): nothing to count, nothing left out
            continue
        group.runs += 1
        if all("stage" in r for r in rows):
            group.counts.update(str(r["stage"]) for r in rows)
        else:
            group.unstaged_runs += 1
    out = []
    for env in sorted({e for e, _ in groups}):
        for method in method_order(m for e, m in groups if e == env):
            out.append(groups[(env, method)])
    return out


def stages_markdown(counts: Sequence[StageCounts], stages: Sequence[str], title: str) -> list[str]:
    """A markdown table: per (env, method) the share (and number) of episodes whose furthest stage was each stage."""
    rows = [c for c in counts if c.episodes]
    if not rows or not stages:
        return []
    header = ["env", "method", "runs", "episodes"] + [
        f"stopped at {s}" if i < len(stages) - 1 else s for i, s in enumerate(stages)
    ]
    lines = [f"### {title}", "", "| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for c in rows:
        cells = [c.env, c.method, str(c.runs - c.unstaged_runs), str(c.episodes)]
        cells += [f"{100.0 * c.counts[s] / c.episodes:.0f}% ({c.counts[s]})" for s in stages]
        lines.append("| " + " | ".join(cells) + " |")
    skipped = [f"{c.method} ({c.unstaged_runs})" for c in counts if c.unstaged_runs]
    if skipped:
        lines += ["", "Runs recorded before episodes had stages are left out: " + ", ".join(skipped) + "."]
    return lines + [""]


def staged_envs(runs: Sequence[Any]) -> Iterator[tuple[str, list[Any], list[str]]]:
    """``(env, its runs, its stages in order)`` for every env of ``runs`` whose records have stages."""
    for env in sorted({run.env for run in runs}):
        env_runs = [run for run in runs if run.env == env]
        stages = stage_order((r for run in env_runs for r in run.episodes), env_runs)
        if stages:
            yield env, env_runs, stages


def stages_section(runs: Sequence[Any]) -> str:
    """The report's stage section (both kinds of episodes, per env with stages), or "" when no run has
    staged records."""
    lines: list[str] = []
    for env, env_runs, stages in staged_envs(runs):
        lines += stages_markdown(
            stage_counts(env_runs, "final_eval"), stages, f"{env}: autonomous test episodes of the last iteration"
        )
        lines += stages_markdown(stage_counts(env_runs, "interactive"), stages, f"{env}: interactive episodes")
    if not lines:
        return ""
    intro = [
        "## How far the episodes got",
        "",
        "The furthest stage of the task each episode reached (pooled over seeds); every stage but the "
        "last is where an unsuccessful episode stopped.",
        "",
    ]
    return "\n".join(intro + lines)
