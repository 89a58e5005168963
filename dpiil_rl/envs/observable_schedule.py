"""When robosuite's observables sample during one control step, worked out without touching them per substep.

robosuite calls ``Observable.update(model_timestep, obs_cache)`` on every observable after every substep
(``MujocoEnv._update_observables``). An observable's timer adds the timestep; it samples its sensor when it
has not sampled in this period and ``sampling_timestep - delay >= time``; when the time reaches the
sampling timestep it samples if it still has not (robosuite prints a warning then), takes the time modulo
the sampling timestep and clears its sampled flag (``robosuite.utils.observables.Observable.update``).
Nothing but the sampling itself reads the simulation, so the substeps at which each observable samples
follow from its timer alone: :func:`sampling_plan` replays that arithmetic (same floats, same order) for a
whole control step, the fast step samples the observables at those substeps (:func:`sample`, the sampling
branch of ``Observable.update``), and :func:`finish` leaves the timers where robosuite's per-substep updates
would have.

Observables whose delayer is not robosuite's ``NO_DELAY`` draw a delay at each sample that moves the next
one; their schedule cannot be known in advance and :func:`sampling_plan` refuses them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np
from robosuite.utils.observables import NO_DELAY

TimerState = tuple[float, bool]  # (time since the last sample, sampled in this period)
SAMPLING_RATE_WARNING = (
    "Warning: sampling rate for observable {} is either too low or delay is too high. Please adjust one (or both)"
)


@dataclass
class SamplingPlan:
    """One control step: ``samples[substep]`` = the observables (in robosuite's order) sampling after it."""

    samples: dict[int, list[Any]] = field(default_factory=dict)
    timers: list[tuple[Any, TimerState]] = field(default_factory=list)  # (observable, its timer at the end)
    late: set[tuple[int, str]] = field(default_factory=set)  # (substep, name): robosuite's too-low-rate samples

    @property
    def substeps(self) -> list[int]:
        return sorted(self.samples)


def _timeline(
    time: float, sampled: bool, period: float, delay: float, timestep: float, substeps: int
) -> tuple[list[tuple[int, bool]], TimerState]:
    """Substeps at which a no-delay observable samples (and whether robosuite warns there), and its final timer."""
    events: list[tuple[int, bool]] = []
    for substep in range(substeps):
        time += timestep
        if not sampled and period - delay >= time:
            events.append((substep, False))
            sampled, delay = True, 0.0  # NO_DELAY draws 0
        if time >= period:
            if not sampled:
                events.append((substep, True))
                delay = 0.0
            time %= period
            sampled = False
    return events, (time, sampled)


def sampling_plan(observables: Mapping[str, Any], timestep: float, substeps: int) -> SamplingPlan:
    """The sampling of every enabled observable over the next ``substeps`` substeps of ``timestep`` s."""
    plan = SamplingPlan()
    memo: dict[tuple[float, bool, float, float], tuple[list[tuple[int, bool]], TimerState]] = {}
    for name, observable in observables.items():
        if not observable._enabled:
            continue
        if observable._delayer is not NO_DELAY:
            raise ValueError(
                f"observable {name!r} has a sampling delayer: the fast step needs robosuite's NO_DELAY "
                "(set env.sim.fast_step: false to step it with robosuite)"
            )
        key = (
            observable._time_since_last_sample,
            observable._sampled,
            observable._sampling_timestep,
            observable._current_delay,
        )
        if key not in memo:
            memo[key] = _timeline(*key, timestep, substeps)
        events, timer = memo[key]
        for substep, late in events:
            plan.samples.setdefault(substep, []).append(observable)
            if late:
                plan.late.add((substep, name))
        plan.timers.append((observable, timer))
    return plan


def sample(plan: SamplingPlan, substep: int, obs_cache: dict[str, Any]) -> None:
    """Sample the observables due after ``substep``, in robosuite's order, as ``Observable.update`` samples:
    sensor -> corrupter -> filter, the observed value, its cache entry, the sampled flag, the next delay."""
    for observable in plan.samples.get(substep, ()):
        if (substep, observable.name) in plan.late:
            print(SAMPLING_RATE_WARNING.format(observable.name))
        obs = np.array(observable._filter(observable._corrupter(observable._sensor(obs_cache))))
        observable._current_observed_value = obs[0] if len(obs.shape) == 1 and obs.shape[0] == 1 else obs
        obs_cache[observable.name] = np.array(observable._current_observed_value)
        observable._sampled = True
        observable._current_delay = observable._delayer()


def finish(plan: SamplingPlan) -> None:
    """Set every observable's timer to where the step's per-substep updates would have left it."""
    for observable, (time, sampled) in plan.timers:
        observable._time_since_last_sample = time
        observable._sampled = sampled
