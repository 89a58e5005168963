"""Where the gate handed control to the expert, and where the robot made contact, around a point.

A study's ``paths.jsonl`` rows hold, for every demo and interactive episode, the controlled point's
position and the gate's ``expert_mode`` and ``risk`` at every step. Around a point of the task (the top
of the peg, the aperture), this module counts

- the share of interactive steps in expert mode within ``radius`` of the point and farther away, and
- for every interactive episode with a contact: how far the point ended from the point's vertical axis,
  at what height, and the gate's risk at its last step over the χ it ran with (χ of iteration k − 1,
  ``metrics.jsonl``), i.e. how close the gate came to asking for help before the contact.

Positions are what the run recorded (the TCP on the real-robot tasks); ``offset`` is added to reach the
point that matters (the ring's centre, 7 cm in front of the TCP on ``ring_real``).
"""

from __future__ import annotations

import math
import statistics
from dataclasses import dataclass, field
from typing import Sequence

from dpiil_rl.study.study_runs import StudyRun, method_order


@dataclass
class GateRegions:
    """Counts of one method over its runs."""

    method: str
    runs: int = 0
    near_steps: int = 0  # interactive steps with the point within ``radius``
    near_expert: int = 0  # ... of them in expert mode
    far_steps: int = 0
    far_expert: int = 0
    interactive_episodes: int = 0
    contact_episodes: int = 0
    contact_requests: list[int] = field(default_factory=list)  # expert steps of every contact episode
    contact_axis_mm: list[float] = field(default_factory=list)  # final distance from the point's vertical axis (mm)
    contact_height: list[float] = field(default_factory=list)  # final height of the point (m)
    contact_risk_over_chi: list[float] = field(default_factory=list)  # risk / χ at the last step (gated methods)

    @property
    def near_share(self) -> float:
        return self.near_expert / self.near_steps if self.near_steps else math.nan

    @property
    def far_share(self) -> float:
        return self.far_expert / self.far_steps if self.far_steps else math.nan


def _check_vector(name: str, value: Sequence[float]) -> list[float]:
    vec = [float(v) for v in value]
    if len(vec) != 3 or not all(math.isfinite(v) for v in vec):
        raise ValueError(f"{name} = {list(value)}: expected three finite numbers [x, y, z] (m)")
    return vec


def _chi_by_iteration(run: StudyRun) -> dict[int, float]:
    return {int(r["iteration"]): float(r["chi"]) for r in run.metrics if r.get("chi") is not None}


def gate_regions(
    runs: Sequence[StudyRun], point: Sequence[float], offset: Sequence[float] = (0.0, 0.0, 0.0), radius: float = 0.03
) -> list[GateRegions]:
    """One :class:`GateRegions` per method (paper order) with interactive episodes in ``runs``."""
    p = _check_vector("point", point)
    o = _check_vector("offset", offset)
    if not radius > 0:
        raise ValueError(f"radius = {radius}: expected a positive distance (m)")
    by_method: dict[str, GateRegions] = {}
    for run in runs:
        rows = run.paths()
        if not rows:
            continue
        stats = by_method.setdefault(run.method, GateRegions(run.method))
        stats.runs += 1
        chi = _chi_by_iteration(run)
        episodes = {int(r["episode"]): r for r in run.episodes}
        for row in rows:
            if row["phase"] != "interactive":
                continue
            if len(row["positions"][0]) != 3:
                raise ValueError(
                    f"{run.run_dir}: paths.jsonl holds {len(row['positions'][0])}-D positions; "
                    "expected 3-D positions (a robot task)"
                )
            stats.interactive_episodes += 1
            moved = [[a + b for a, b in zip(q, o)] for q in row["positions"]]
            for q, expert in zip(moved, row["expert_mode"]):
                near = math.dist(q, p) < radius
                stats.near_steps += near
                stats.far_steps += not near
                stats.near_expert += bool(expert) and near
                stats.far_expert += bool(expert) and not near
            episode = episodes[int(row["episode"])]
            if not episode["collision"]:
                continue
            stats.contact_episodes += 1
            stats.contact_requests.append(int(episode["expert_steps"]))
            end = moved[-1]
            stats.contact_axis_mm.append(1000.0 * math.hypot(end[0] - p[0], end[1] - p[1]))
            stats.contact_height.append(end[2])
            k = int(row["iteration"]) - 1
            if k in chi and row["risk"] and chi[k] > 0:
                stats.contact_risk_over_chi.append(float(row["risk"][-1]) / chi[k])
    return [by_method[m] for m in method_order(by_method) if by_method[m].interactive_episodes]


def _median(values: list[float], fmt: str) -> str:
    return format(statistics.median(values), fmt) if values else "–"


def _span(values: list[float], fmt: str) -> str:
    return f"{format(min(values), fmt)}–{format(max(values), fmt)}" if values else "–"


def regions_table(stats: Sequence[GateRegions], radius: float) -> str:
    """A markdown table of :func:`gate_regions`' counts."""
    cm = f"{100 * radius:g} cm"
    lines = [
        f"| method | runs | expert share within {cm} | expert share farther | contact episodes | "
        "contacts with no request | distance from the axis at contact (mm, median, range) | height at contact (m) | "
        "risk / χ at contact (median, max) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for s in stats:
        no_request = sum(1 for n in s.contact_requests if n == 0)
        risk = (
            f"{_median(s.contact_risk_over_chi, '.2f')}, {max(s.contact_risk_over_chi):.2f}"
            if s.contact_risk_over_chi
            else "–"
        )
        lines.append(
            f"| {s.method} | {s.runs} | {s.near_share:.2f} ({s.near_steps} steps) | "
            f"{s.far_share:.2f} ({s.far_steps} steps) | "
            f"{s.contact_episodes} of {s.interactive_episodes} | {no_request} | "
            f"{_median(s.contact_axis_mm, '.1f')} ({_span(s.contact_axis_mm, '.1f')}) | "
            f"{_span(s.contact_height, '.3f')} | {risk} |"
        )
    return "\n".join(lines)
