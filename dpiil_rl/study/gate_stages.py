"""Where the gate handed control to the person, by stage of a multi-stage task.

On a staged task (the ring: reach → grasped → lifted → at_peg → threaded) every ``paths.jsonl`` row of a
demo or interactive episode lists, per step, the gate's ``expert_mode`` and the ``stage`` of the state the
step was decided in. Pooled over a method's runs, this counts the interactive steps per stage and how many
of them the person controlled, so a table can say *where* each method spends the person's effort: DPIIL
should ask where the person was slow and steady and the policy unsure (grasp, insertion), a
variance-only gate wherever the ensemble disagrees.

Runs recorded before paths had per-step stages have no ``stage`` in their rows and are left out (and
counted as such).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Any, Iterable, Sequence

from dpiil_rl.study.stage_table import staged_envs
from dpiil_rl.study.study_runs import method_order

Row = dict[str, Any]


@dataclass
class GateStages:
    """Interactive steps of one (env, method) per stage, and those the person controlled, over its runs."""

    env: str
    method: str
    runs: int = 0  # runs whose interactive paths have per-step stages
    steps: Counter = field(default_factory=Counter)  # stage index -> interactive steps in that stage
    expert: Counter = field(default_factory=Counter)  # stage index -> of them, steps the person controlled
    unstaged_runs: int = 0  # runs with interactive paths but no per-step stage (recorded before stages)

    @property
    def expert_steps(self) -> int:
        return sum(self.expert.values())


def count_gate_stages(rows: Iterable[Row], num_stages: int, phase: str = "interactive") -> tuple[Counter, Counter, int]:
    """``(steps, expert, paths)`` of the ``phase`` rows of one run's ``paths.jsonl``: steps per stage index,
    person-controlled steps per stage index, and the number of paths counted. A row of ``phase`` without
    ``stage`` is an error (a run is counted whole or not at all: see :func:`gate_stage_counts`)."""
    steps: Counter = Counter()
    expert: Counter = Counter()
    paths = 0
    for row in rows:
        if row["phase"] != phase:
            continue
        stages, modes = row["stage"], row["expert_mode"]
        if len(stages) != len(modes):
            raise ValueError(
                f"path of episode {row.get('episode')}: {len(stages)} stages for {len(modes)} steps "
                "(expected one stage per step)"
            )
        for s, m in zip(stages, modes):
            if not 0 <= int(s) < num_stages:
                raise ValueError(f"path of episode {row.get('episode')}: stage {s} (expected 0..{num_stages - 1})")
            steps[int(s)] += 1
            expert[int(s)] += bool(m)
        paths += 1
    return steps, expert, paths


def gate_stage_counts(runs: Sequence[Any], num_stages: int, phase: str = "interactive") -> list[GateStages]:
    """One :class:`GateStages` per (env, run name) of ``runs`` (objects with ``env``, ``method``, ``paths()``
    and, optionally, ``run_name``: a method's variants are rows of their own), in env then paper order.
    Methods without ``phase`` paths (BC) are left out."""
    groups: dict[tuple[str, str], GateStages] = {}
    for run in runs:
        rows = [r for r in run.paths() if r["phase"] == phase]
        if not rows:
            continue
        name = getattr(run, "run_name", None) or run.method
        group = groups.setdefault((run.env, name), GateStages(run.env, name))
        if not all("stage" in r for r in rows):
            group.unstaged_runs += 1
            continue
        steps, expert, _ = count_gate_stages(rows, num_stages, phase)
        group.steps.update(steps)
        group.expert.update(expert)
        group.runs += 1
    out = []
    for env in sorted({e for e, _ in groups}):
        out += [groups[(env, m)] for m in method_order(m for e, m in groups if e == env)]
    return out


def gate_stages_markdown(counts: Sequence[GateStages], stages: Sequence[str], title: str) -> list[str]:
    """Per (env, method): the share of the person's interactive steps in each stage and, in brackets, the
    share of that stage's steps the person controlled."""
    rows = [c for c in counts if c.runs and sum(c.steps.values())]
    if not rows:
        skipped = [f"{c.method} ({c.unstaged_runs})" for c in counts if c.unstaged_runs]
        return (
            [
                f"### {title}",
                "",
                "No run has per-step stages in its paths yet (recorded before they existed): "
                + ", ".join(skipped)
                + ".",
                "",
            ]
            if skipped
            else []
        )
    shown = [i for i in range(len(stages)) if any(c.steps[i] for c in rows)]  # not the last: episodes end there
    header = ["env", "method", "runs", "person's steps"] + [stages[i] for i in shown]
    lines = [f"### {title}", "", "| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for c in rows:
        cells = [c.env, c.method, str(c.runs), f"{c.expert_steps:,}"]
        for i in shown:
            share = f"{100.0 * c.expert[i] / c.expert_steps:.0f}%" if c.expert_steps else "–"
            ctrl = f"{100.0 * c.expert[i] / c.steps[i]:.0f}%" if c.steps[i] else "–"
            cells.append(f"{share} ({ctrl} of {c.steps[i]:,})")
        lines.append("| " + " | ".join(cells) + " |")
    lines += [
        "",
        "Per stage: the share of the person's interactive steps spent there and, in brackets, the share "
        "of all interactive steps in that stage the person controlled.",
    ]
    skipped = [f"{c.method} ({c.unstaged_runs})" for c in counts if c.unstaged_runs]
    if skipped:
        lines += ["", "Runs recorded before paths had per-step stages are left out: " + ", ".join(skipped) + "."]
    return lines + [""]


def gate_stages_section(runs: Sequence[Any]) -> str:
    """The report's section on where the person was asked to act (per env with stages), or "" when no env
    has stages. Reads ``paths.jsonl`` only for runs of staged envs."""
    lines: list[str] = []
    for env, env_runs, stages in staged_envs(runs):
        lines += gate_stages_markdown(
            gate_stage_counts(env_runs, len(stages)),
            stages,
            f"{env}: interactive steps the person controlled, by stage",
        )
    if not lines:
        return ""
    return "\n".join(
        [
            "## Where the person was asked to act",
            "",
            "Every interactive step's stage (the state the gate decided in), pooled over seeds.",
            "",
        ]
        + lines
    )
