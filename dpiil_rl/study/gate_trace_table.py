"""The gate traces of a study in tables: what each method's gate reads along the task, by stage and by speed.

Reads the runs' ``evaluations/gate_trace_<n>ep.jsonl`` (:mod:`dpiil_rl.training.gate_trace`: the saved final
policy alone, the gate's components at every step). Per method, pooled over its seeds:

- by stage: steps, the robot's median speed, the median μ_λ(s) and σ_λ(s), the median risk / χ and the
  share of steps with risk > χ (where the gate would have handed over);
- per seed, then mean with a bootstrap 95% interval over seeds: Spearman's rank correlation of μ_λ(s) with
  the robot's own speed coming into s (does the precision estimate read the robot's speed?) and of the risk
  with it;
- by robot-speed bin: the share of steps with risk > χ.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from dpiil_rl.records.run_files import read_jsonl
from dpiil_rl.study.intervals import bootstrap_ci
from dpiil_rl.study.ring_safety import SPEED_BINS, spearman
from dpiil_rl.study.study_runs import StudyRun, method_order


@dataclass
class MethodTrace:
    method: str
    seeds: list[int] = field(default_factory=list)
    steps: dict[str, list[np.ndarray]] = field(default_factory=dict)  # component -> per seed, all steps


def trace_name(episodes: int) -> str:
    return f"gate_trace_{int(episodes)}ep"


def load_traces(runs: Sequence[StudyRun], episodes: int, speed_scale: float = 1.0) -> list[MethodTrace]:
    """Every run's saved trace of ``episodes`` episodes, grouped by method (runs without one are left out)."""
    groups: dict[str, MethodTrace] = {}
    for run in sorted(runs, key=lambda r: (r.run_name, r.seed)):
        rows = read_jsonl(Path(run.run_dir) / "evaluations" / f"{trace_name(episodes)}.jsonl")
        if not rows:
            continue
        g = groups.setdefault(run.run_name, MethodTrace(run.run_name))  # a method, or a variant of it
        g.seeds.append(run.seed)
        per: dict[str, Any] = {
            k: np.concatenate([np.asarray(r[k], dtype=float) for r in rows])
            for k in ("action_var", "speed_mu", "speed_sigma", "risk", "speed")
        }
        per["speed"] = per["speed"] * speed_scale
        per["ratio"] = per["risk"] / np.concatenate([np.full(len(r["risk"]), float(r["chi"])) for r in rows])
        if all("stage" in r for r in rows):
            per["stage"] = np.concatenate([np.asarray(r["stage"], dtype=float) for r in rows])
        for k, v in per.items():
            g.steps.setdefault(k, []).append(v)
    return [groups[m] for m in method_order(groups)]


def _pooled(g: MethodTrace, key: str) -> np.ndarray:
    return np.concatenate(g.steps[key]) if g.steps.get(key) else np.array([])


def _med(x: np.ndarray) -> str:
    x = x[np.isfinite(x)]
    return "–" if x.size == 0 else f"{float(np.median(x)):.3g}"


def _share(x: np.ndarray) -> str:
    x = x[np.isfinite(x)]
    return "–" if x.size == 0 else f"{100.0 * float(np.mean(x > 1.0)):.1f}%"


def _mean_ci(values: Sequence[float]) -> str:
    v = [x for x in values if not math.isnan(x)]
    if not v:
        return "–"
    lo, hi = bootstrap_ci(v)
    return f"{np.mean(v):+.2f}" + ("" if math.isnan(lo) else f" [{lo:+.2f}, {hi:+.2f}]")


def correlation(g: MethodTrace, key: str) -> list[float]:
    """Per seed: Spearman's correlation of ``key`` with the robot's speed (steps with a speed)."""
    out = []
    for values, speed in zip(g.steps[key], g.steps["speed"]):
        ok = np.isfinite(speed) & np.isfinite(values)
        out.append(spearman(speed[ok].tolist(), values[ok].tolist()))
    return out


def gate_trace_markdown(
    traces: Sequence[MethodTrace], stage_names: Sequence[str], episodes: int, unit: str, command: str
) -> str:
    lines = [
        "# What the gates read along the task",
        "",
        f"Made by `{command}`. Each run's final policy alone for {episodes} episodes on the same start states; at "
        "every step the gate's components as its saved modules compute them (nothing acts on them). *Speed*: "
        f"the robot's end-effector speed coming into the state ({unit} per step). *Would hand over*: share of "
        "steps with risk > χ.",
        "",
        "## Does the precision estimate read the robot's own speed?",
        "",
        "Spearman's rank correlation with the robot's speed, per seed, mean [bootstrap 95% over seeds].",
        "",
        "| method | seeds | steps | μ_λ(s) vs speed | risk vs speed |",
        "|---|---|---|---|---|",
    ]
    for g in traces:
        lines.append(
            f"| {g.method} | {len(g.seeds)} | {_pooled(g, 'speed').size:,} | {_mean_ci(correlation(g, 'speed_mu'))} "
            f"| {_mean_ci(correlation(g, 'risk'))} |"
        )
    lines += ["", "## By stage", ""]
    lines += [
        "| method | stage | steps | robot speed | μ_λ(s) | σ_λ(s) | σ²_θ(s) | risk / χ | would hand over |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for g in traces:
        stage = _pooled(g, "stage")
        for i, name in enumerate(stage_names or ["all"]):
            sel = stage == i if stage.size else np.ones(_pooled(g, "speed").size, bool)
            if not sel.any():
                continue
            cols = [_med(_pooled(g, k)[sel]) for k in ("speed", "speed_mu", "speed_sigma", "action_var", "ratio")]
            share = _share(_pooled(g, "ratio")[sel])
            lines.append(f"| {g.method} | {name} | {int(sel.sum()):,} | " + " | ".join(cols) + f" | {share} |")
    lines += ["", "## Would hand over, by the robot's speed", ""]
    bins = list(SPEED_BINS)
    header = [f"{lo:g}–{hi:g}" if math.isfinite(hi) else f"≥ {lo:g}" for lo, hi in zip(bins[:-1], bins[1:])]
    lines += ["| method | " + " | ".join(header) + " |", "|---|" + "---|" * len(header)]
    for g in traces:
        speed, ratio = _pooled(g, "speed"), _pooled(g, "ratio")
        cells = []
        for lo, hi in zip(bins[:-1], bins[1:]):
            sel = (speed >= lo) & (speed < hi)
            cells.append("–" if not sel.any() else f"{_share(ratio[sel])} ({int(sel.sum()):,})")
        lines.append(f"| {g.method} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"
