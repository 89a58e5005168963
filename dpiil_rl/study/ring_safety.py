"""Why a gate was less safe while learning the ring: where its interactive failures and contacts were, and
what its risk did along the task, from a run's records alone.

Per finished ring run (:func:`run_safety`) this reads ``episodes.jsonl`` (each interactive episode's
success, contacts and furthest ``stage``) and ``paths.jsonl`` (every interactive step's ``expert_mode``,
``risk``, end-effector position and, in runs recorded since per-step stages, its ``stage``) and keeps:

- failed interactive episodes and episodes with a contact, and their contact steps, by the episode's furthest
  stage. Contacts are recorded per episode, not per step, so *where* a contact happened is only known up to
  the furthest stage of its episode;
- per stage of the step's state (and over all steps, :data:`ALL`, also for runs without per-step stages): the
  steps, those the expert drove, and for a *threshold gate* the risk relative to its threshold χ. A run's
  gate is a threshold gate when every interactive step of iteration k is in expert mode exactly when its
  risk exceeds the χ calibrated after iteration k − 1 (``metrics.jsonl``): DPIIL and EnsembleDAgger are,
  gates with memory or other thresholds (ThriftyDAgger, HG-DAgger, DAgger) are not;
- the robot's own speed where the gate could hand over: at every step whose previous step the robot drove,
  the end-effector speed coming into the state (``‖pos_t − pos_{t−1}‖``, cm per step: what the state's joint
  velocities show the speed head), split by whether the gate handed over at that step, and the rank
  correlation of that speed with the risk;
- of each failed episode, the share of its steps the expert drove, the steps the robot drove alone at its
  end (the gate silent while the episode ran out) and, when it drove the last :data:`WINDOW` steps, its speed
  and the risk relative to χ over them: how the robot and the gate were doing as the episode ran out.

:func:`method_safety` groups runs per (study, method); its per-seed values are what the report bootstraps.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field
from typing import Any, Callable, Iterable, Sequence

import numpy as np
from scipy import stats

from dpiil_rl.study.intervals import bootstrap_ci
from dpiil_rl.study.stage_table import stage_order
from dpiil_rl.study.study_runs import method_order

Row = dict[str, Any]

#: the pseudo-stage "every interactive step" (kept for every run, with or without per-step stages)
ALL = -1
#: metres to centimetres (speeds are reported in cm per control step)
CM = 100.0
#: the last steps of a failed episode described (the robot's speed, the risk / χ) when the robot drove all of them
WINDOW = 20
#: robot-speed bins (cm per step) of the hand-over curve
SPEED_BINS: tuple[float, ...] = (0.0, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0, math.inf)


@dataclass
class FailedEpisode:
    """How a failed interactive episode ended (from its path)."""

    stage: str  # the furthest stage it reached
    last_stage: str | None  # the stage of its last step's state (None: the path has no per-step stages)
    expert_share: float  # share of its steps in expert mode
    final_auto: int  # steps the robot drove alone at its end (0: the expert had control as it ran out)
    final_speed: float  # robot's median speed (cm/step) over the last WINDOW steps, all its own (nan: fewer alone)
    final_risk_ratio: float  # median risk / χ over those steps (nan: fewer alone, or not a threshold gate)


@dataclass
class RunSafety:
    """The safety records of one ring run (see the module docstring); stage keys are stage indices or :data:`ALL`."""

    study: str
    method: str
    seed: int
    stages: list[str]
    episodes: int = 0  # interactive episodes
    success: float = math.nan  # interactive success (the run's recomputed summary)
    failures: Counter = field(default_factory=Counter)  # furthest stage name -> failed interactive episodes
    contacts: Counter = field(default_factory=Counter)  # furthest stage name -> interactive episodes with a contact
    contact_steps: Counter = field(default_factory=Counter)  # furthest stage name -> their contact steps
    staged: bool = False  # every interactive path has per-step stages
    gate_agreement: float = math.nan  # share of interactive steps with expert_mode == (risk > χ of the refit before)
    steps: Counter = field(default_factory=Counter)  # stage -> interactive steps
    expert: Counter = field(default_factory=Counter)  # stage -> of them, steps in expert mode
    risk_ratio: dict[int, list[float]] = field(default_factory=dict)  # stage -> risk / χ per step (threshold gates)
    speed: dict[int, list[float]] = field(default_factory=dict)  # stage -> robot's speed at robot-driven steps
    risk: dict[int, list[float]] = field(default_factory=dict)  # stage -> the risk at those same steps
    handed_over: dict[int, list[bool]] = field(default_factory=dict)  # stage -> the gate handed over at that step
    failed: list[FailedEpisode] = field(default_factory=list)  # every failed interactive episode with a path

    @property
    def threshold_gate(self) -> bool:
        return self.gate_agreement == 1.0

    def stage_keys(self) -> list[int]:
        return [ALL] + (list(range(len(self.stages))) if self.staged else [])


def _chi_before(metrics: Sequence[Row]) -> dict[int, float]:
    """χ in force during iteration k (calibrated after iteration k − 1), for each k with a recorded χ before it."""
    chi = {int(r["iteration"]): r.get("chi") for r in metrics}
    return {k + 1: float(v) for k, v in chi.items() if v is not None and math.isfinite(float(v))}


def _floats(values: Iterable[Any]) -> np.ndarray:
    return np.array([math.nan if v is None else float(v) for v in values], dtype=float)


def final_auto_steps(expert_mode: Sequence[bool]) -> int:
    """Steps at the end of an episode that the robot drove alone (since the expert last had control)."""
    n = 0
    for mode in reversed(expert_mode):
        if mode:
            break
        n += 1
    return n


def run_safety(run: Any, study: str, paths: Sequence[Row] | None = None) -> RunSafety:
    """The safety records of one finished ring run (a :class:`~dpiil_rl.study.study_runs.StudyRun`, or any
    object with ``method``, ``seed``, ``episodes``, ``metrics``, ``summary``, ``recorded`` and ``paths()``)."""
    stages = stage_order((r for r in run.episodes), [run])
    if not stages:
        raise ValueError(f"{study}/{run.method}/seed_{run.seed}: no stages in its records (expected ring runs)")
    out = RunSafety(study, run.method, int(run.seed), stages)
    interactive = [r for r in run.episodes if r["phase"] == "interactive"]
    out.episodes = len(interactive)
    success = run.summary.get("interactive_success") if interactive else None
    out.success = math.nan if success is None else float(success)
    by_episode = {int(r["episode"]): r for r in interactive}
    for r in interactive:
        if "stage" not in r:
            raise ValueError(f"{study}/{run.method}/seed_{run.seed}: episode {r['episode']} has no stage")
        if not r["success"]:
            out.failures[str(r["stage"])] += 1
        if r["collision"]:
            out.contacts[str(r["stage"])] += 1
            out.contact_steps[str(r["stage"])] += int(r.get("collision_steps", 1))
    rows = [p for p in (run.paths() if paths is None else paths) if p["phase"] == "interactive"]
    if not rows:
        return out
    out.staged = all("stage" in p for p in rows)
    chi = _chi_before(run.metrics)
    agree = total = 0
    ratios: list[tuple[np.ndarray, np.ndarray]] = []
    for p in rows:
        mode = np.array(p["expert_mode"], dtype=bool)
        risk = _floats(p["risk"])
        stage = np.array(p["stage"], dtype=int) if out.staged else np.full(mode.shape, ALL)
        pos = np.asarray(p["positions"], dtype=float)
        if not (len(risk) == len(stage) == len(mode) == len(pos) - 1):
            raise ValueError(
                f"{study}/{run.method}/seed_{run.seed}: path of episode {p['episode']} has {len(mode)} modes, "
                f"{len(risk)} risks, {len(stage)} stages and {len(pos)} positions (expected T, T, T and T + 1)"
            )
        k = int(p["iteration"])
        if k in chi and np.isfinite(risk).all():
            agree += int(((risk > chi[k]) == mode).sum())
            ratios.append((stage, risk / chi[k]))
        total += len(mode)
        speed = np.r_[math.nan, np.linalg.norm(np.diff(pos[:-1], axis=0), axis=1) * CM]  # into the state of step t
        robot_drove = np.r_[False, ~mode[:-1]]  # the step before was the robot's own
        for key in (ALL,) + ((tuple(int(s) for s in np.unique(stage))) if out.staged else ()):
            at = np.ones(mode.shape, dtype=bool) if key == ALL else stage == key
            out.steps[key] += int(at.sum())
            out.expert[key] += int((mode & at).sum())
            sel = at & robot_drove
            out.speed.setdefault(key, []).extend(speed[sel].tolist())
            out.risk.setdefault(key, []).extend(risk[sel].tolist())
            out.handed_over.setdefault(key, []).extend(mode[sel].tolist())
        episode = by_episode.get(int(p["episode"]))
        if episode is not None and not episode["success"]:
            n = final_auto_steps(mode.tolist())
            alone = n >= WINDOW and len(mode) >= WINDOW  # the robot drove the last WINDOW steps
            last = slice(len(mode) - WINDOW, len(mode))
            out.failed.append(
                FailedEpisode(
                    stage=str(episode["stage"]),
                    last_stage=stages[int(stage[-1])] if out.staged and len(stage) else None,
                    expert_share=float(mode.mean()) if len(mode) else math.nan,
                    final_auto=n,
                    final_speed=_median(np.linalg.norm(np.diff(pos[last.start :], axis=0), axis=1) * CM)
                    if alone
                    else math.nan,
                    final_risk_ratio=_median(risk[last] / chi[k]) if alone and k in chi else math.nan,
                )
            )
    out.gate_agreement = agree / total if total and len(ratios) == len(rows) else math.nan
    if not out.threshold_gate:  # a risk relative to χ means nothing for gates that are not risk > χ
        for f in out.failed:
            f.final_risk_ratio = math.nan
    else:
        for stage, ratio in ratios:
            out.risk_ratio.setdefault(ALL, []).extend(ratio.tolist())
            if out.staged:
                for key in np.unique(stage):
                    out.risk_ratio.setdefault(int(key), []).extend(ratio[stage == key].tolist())
    return out


def spearman(x: Sequence[float], y: Sequence[float]) -> float:
    """Rank correlation of the finite pairs of ``x`` and ``y``; nan with fewer than 3 or a constant side."""
    a, b = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    ok = np.isfinite(a) & np.isfinite(b)
    if ok.sum() < 3 or np.ptp(a[ok]) == 0 or np.ptp(b[ok]) == 0:
        return math.nan
    rho = stats.spearmanr(a[ok], b[ok])[0]  # the statistic (scipy's result type hides its fields from checkers)
    return float(rho)


def _median(values: Sequence[float] | np.ndarray) -> float:
    a = np.asarray(values, dtype=float)
    a = a[np.isfinite(a)]
    return float(np.median(a)) if a.size else math.nan


@dataclass
class MethodSafety:
    """One method's runs of one study, with per-seed values (for intervals over seeds) and pooled samples."""

    study: str
    method: str
    runs: list[RunSafety]

    @property
    def stages(self) -> list[str]:
        return self.runs[0].stages

    @property
    def interactive(self) -> list[RunSafety]:
        return [r for r in self.runs if r.episodes]

    def staged_runs(self) -> list[RunSafety]:
        return [r for r in self.interactive if r.staged]

    def runs_for(self, key: int) -> list[RunSafety]:
        """The interactive runs that have per-step values for stage ``key`` (all of them for :data:`ALL`)."""
        return self.interactive if key == ALL else self.staged_runs()

    def per_seed(self, value: Callable[[RunSafety], float], key: int = ALL) -> list[float]:
        """``value(run)`` of every run with values for ``key``, leaving out nan (a stage a run never reached)."""
        out = [value(r) for r in self.runs_for(key)]
        return [v for v in out if math.isfinite(v)]

    def failure_rate(self, stage: str) -> list[float]:
        """Per seed: failed interactive episodes whose furthest stage was ``stage``, per 100 interactive episodes."""
        return [100.0 * r.failures[stage] / r.episodes for r in self.interactive]

    def contact_rate(self, stage: str) -> list[float]:
        """Per seed: interactive episodes with a contact whose furthest stage was ``stage``, per 100 episodes."""
        return [100.0 * r.contacts[stage] / r.episodes for r in self.interactive]

    def expert_share(self, key: int) -> list[float]:
        return self.per_seed(lambda r: r.expert[key] / r.steps[key] if r.steps[key] else math.nan, key)

    def handover_rate(self, key: int) -> list[float]:
        """Per seed: the share of robot-driven steps at which the gate handed over."""
        return self.per_seed(lambda r: float(np.mean(r.handed_over[key])) if r.handed_over.get(key) else math.nan, key)

    def speed_median(self, key: int, handed_over: bool) -> list[float]:
        """Per seed: the robot's median speed (cm/step) at the steps where the gate did (or did not) hand over."""

        def med(r: RunSafety) -> float:
            speed, mode = np.asarray(r.speed.get(key, []), dtype=float), np.asarray(r.handed_over.get(key, []), bool)
            return _median(speed[mode == handed_over]) if speed.size else math.nan

        return self.per_seed(med, key)

    def speed_risk_correlation(self, key: int) -> list[float]:
        """Per seed: Spearman's correlation of the robot's speed and the gate's risk at robot-driven steps."""
        return self.per_seed(lambda r: spearman(r.speed.get(key, []), r.risk.get(key, [])), key)

    def pooled(self, attr: str, key: int) -> np.ndarray:
        """A per-step sample pooled over the runs with values for ``key`` (``speed``, ``risk_ratio``, ...)."""
        values = [v for r in self.runs_for(key) for v in getattr(r, attr).get(key, [])]
        return np.asarray(values, dtype=float)


def method_safety(runs: Sequence[RunSafety]) -> list[MethodSafety]:
    """Runs grouped per (study, method): studies in the order first seen, methods in the paper's order."""
    studies = list(dict.fromkeys(r.study for r in runs))
    out = []
    for study in studies:
        mine = [r for r in runs if r.study == study]
        for method in method_order(r.method for r in mine):
            out.append(
                MethodSafety(study, method, sorted((r for r in mine if r.method == method), key=lambda r: r.seed))
            )
    return out


def mean_ci(values: Sequence[float]) -> tuple[float, float, float]:
    """``(mean, low, high)``: the mean over seeds and its 95% percentile-bootstrap interval (nan, nan with < 2)."""
    if not len(values):
        return math.nan, math.nan, math.nan
    low, high = bootstrap_ci(values)
    return float(np.mean(values)), low, high


def handover_curve(group: MethodSafety, key: int, bins: Sequence[float] = SPEED_BINS) -> list[tuple[float, float, int]]:
    """Pooled over seeds: per robot-speed bin ``[lo, hi)``, ``(lo, hand-over share, steps)`` (share nan when empty)."""
    speed = group.pooled("speed", key)
    mode = np.asarray([v for r in group.runs_for(key) for v in r.handed_over.get(key, [])], dtype=bool)
    ok = np.isfinite(speed)
    speed, mode = speed[ok], mode[ok]
    out = []
    for lo, hi in zip(bins[:-1], bins[1:]):
        sel = (speed >= lo) & (speed < hi)
        n = int(sel.sum())
        out.append((float(lo), float(mode[sel].mean()) if n else math.nan, n))
    return out
