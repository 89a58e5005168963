"""Ring-task benchmarks (``make bench``): our env and collector vs raw robosuite, the fast step, workers, the expert.

Stepping (:func:`step_rates`), four sides on one motion, reset every ``max_steps`` (200) steps, the env's horizon:

- ``ring_env_fps``: :class:`~dpiil_rl.envs.ring.RingEnv` (TorchRL, 6-D actions, roll hold, collision flags,
  stage, horizon 200, the configured step: ``sim.fast_step``), one simulation in this process, on a random
  6-D stream; it records the 7-D commands its step sends (the stream plus the roll hold);
- ``raw_robosuite_fps``: robosuite's ``NutAssemblyRound`` stepped directly by its own ``env.step`` with
  exactly those commands: the same motion, so the same physics cost (a different stream moved the ratio by
  2 points);
- ``fast_step_fps``: the same raw env stepped by :class:`~dpiil_rl.envs.ring_fast_step.FastStep` on the
  same commands (the step alone, no TorchRL);
- ``physics_fps``: the ceiling: the same scene along the same motion with no controller, ``mj_step`` x 25
  per control step from each control step's recorded MuJoCo state (its ``ctrl`` held).

The sides take turns episode by episode within each round, and every ratio is the median of the rounds'
ratios, so a change of machine load does not enter it (with best-of-N of each side, ``env_vs_raw`` moved
0.90-0.98 from run to run).

- ``collector_fps``: whole episodes through :class:`InterventionCollector` with the learner's policy
  (an untrained 5-member ensemble acting alone), the loop the evaluation runs; ``bare_policy_loop_fps``:
  the same policy, env and seed in a bare loop. The learner moves differently from the random stream
  (its physics costs differ), so ``collector_vs_raw`` = ``env_vs_raw`` x ``collector_vs_bare_loop``,
  each measured on one action stream.
- ``workers_fps``: two simulations stepped by two worker processes vs one in this process.
- ``expert_statistics``: the scripted expert alone over N episodes (success, length, collisions), with the
  fast step (``scripted_expert_ring``) and with robosuite's ``env.step`` from the same seeds:
  ``fast_step_agreement`` compares the two (in contact tiny differences grow, so episodes differ one by
  one; the rates and lengths must agree within noise: Fisher's exact test on the successes, Welch's t on
  the lengths of the threaded episodes).
"""

from __future__ import annotations

import statistics
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import mujoco as _mujoco
import numpy as np
import torch
from omegaconf import DictConfig, OmegaConf
from scipy import stats
from tensordict.nn import TensorDictSequential

from dpiil_rl.collectors.expert_switch import ExpertSwitch
from dpiil_rl.collectors.intervention import InterventionCollector, run_episodes
from dpiil_rl.collectors.stop_rules import EpisodeBudget
from dpiil_rl.envs.ring_fast_step import FastStep
from dpiil_rl.hooks.evaluate import autonomous_policy
from dpiil_rl.modules.gate import ConstantGate
from dpiil_rl.training.factory import build_env, make_actor, make_expert
from dpiil_rl.utils.robosuite_import import quiet_robosuite

if TYPE_CHECKING:
    from dpiil_rl.envs.ring import RingEnv

# MuJoCo's bindings are compiled modules without type information: their names are Any to the type checker
mujoco: Any = _mujoco
ROOT = Path(__file__).resolve().parents[1]
HORIZON = int(
    OmegaConf.load(ROOT / "configs/env/ring.yaml").max_steps
)  # steps per episode of the stepping benchmarks; each side resets after it
STATE = mujoco.mjtState.mjSTATE_INTEGRATION  # qpos, qvel, act, ctrl, warm start, ...: what a step starts from


def _cfg(workers: int = 0, fast_step: bool | None = None) -> DictConfig:
    cfg = cast(DictConfig, OmegaConf.load(ROOT / "configs/env/ring.yaml"))
    cfg.workers = workers
    if fast_step is not None:
        cfg.sim.fast_step = fast_step
    return cfg


def _actions(steps: int) -> torch.Tensor:
    """The random 6-D action stream both loops replay (|a| <= 0.3)."""
    return (torch.rand(steps, 6, generator=torch.Generator().manual_seed(0)) * 2 - 1) * 0.3


def _raw_env():
    """robosuite's ``NutAssemblyRound`` as our simulations build it, without our env around it."""
    with quiet_robosuite():
        import robosuite
        from robosuite.controllers import load_composite_controller_config

    cfg = _cfg()
    return robosuite.make(
        "NutAssemblyRound",
        robots=cfg.sim.robot,
        controller_configs=load_composite_controller_config(controller=cfg.sim.controller, robot=cfg.sim.robot),
        has_renderer=False,
        has_offscreen_renderer=False,
        use_camera_obs=False,
        ignore_done=True,
        hard_reset=False,
        horizon=10_000,
        control_freq=cfg.sim.control_freq,
        reward_shaping=False,
        seed=0,
    )


class _Side:
    """One way of stepping the ring scene: ``run(k)`` steps chunk ``k`` of the stream (one horizon, then a reset)
    and returns the seconds it took; ``start_round()`` puts it back at the stream's first episode (untimed)."""

    def start_round(self) -> None:
        raise NotImplementedError

    def run(self, chunk: int) -> float:
        raise NotImplementedError


class _RingEnvSide(_Side):
    """:class:`~dpiil_rl.envs.ring.RingEnv` (TorchRL, as configured) on the random 6-D stream; its first pass
    records the 7-D commands its step sends (roll hold included) and is not timed."""

    def __init__(self, steps: int) -> None:
        self.env = build_env(_cfg(0), 1, seed=0)
        self.actions = _actions(steps).reshape(steps, 1, 6)
        sim = cast("RingEnv", self.env.base_env).sims._sims[0]  # the (in-process) simulation
        step, recorded = sim._env_step, []  # robosuite's env.step or the fast step, as configured

        def recording_step(action: np.ndarray):
            recorded.append(np.array(action))
            return step(action)

        sim._env_step = recording_step
        self.start_round()
        for chunk in range(steps // HORIZON):
            self.run(chunk)
        sim._env_step = step
        self.commands = np.stack(recorded)

    def start_round(self) -> None:
        self.env.set_seed(0)
        self.td = self.env.reset()

    def run(self, chunk: int) -> float:
        td, actions = self.td, self.actions[chunk * HORIZON : (chunk + 1) * HORIZON]
        t0 = time.perf_counter()
        for action in actions:  # the last step ends the episode (horizon): step_and_maybe_reset resets
            td["action"] = action
            _, td = self.env.step_and_maybe_reset(td)
        elapsed = time.perf_counter() - t0
        self.td = td
        return elapsed


class _RawSide(_Side):
    """robosuite's ``NutAssemblyRound`` without our env, stepped on the recorded 7-D commands by its own
    ``env.step`` or by :class:`FastStep`; ``states`` (if given) collects the MuJoCo state before each step."""

    def __init__(self, commands: np.ndarray, fast: bool) -> None:
        self.env, self.commands = _raw_env(), commands
        self.step = FastStep(self.env).step if fast else self.env.step

    def start_round(self) -> None:
        self.env.rng.bit_generator.state = np.random.PCG64(0).state  # the same placements every round
        self.env.reset()

    def run(self, chunk: int, states: list | None = None) -> float:
        env, step = self.env, self.step
        model, data = env.sim.model._model, env.sim.data._data
        t0 = time.perf_counter()
        for command in self.commands[chunk * HORIZON : (chunk + 1) * HORIZON]:
            if states is not None:
                state = np.empty(mujoco.mj_stateSize(model, STATE))
                mujoco.mj_getState(model, data, state, STATE)
                states.append(state)
            step(command)
        env.reset()
        return time.perf_counter() - t0


class _PhysicsSide(_Side):
    """The ceiling: the same scene along the same motion with no controller: from each recorded state before a
    control step, ``mj_step`` x the env's substeps with its ``ctrl`` held; only the stepping is timed."""

    def __init__(self, fast: _RawSide) -> None:
        self.states: list = []
        fast.start_round()
        for chunk in range(len(fast.commands) // HORIZON):
            fast.run(chunk, self.states)
        self.env = _raw_env()
        self.env.reset()
        self.substeps = int(self.env.control_timestep / self.env.model_timestep)

    def start_round(self) -> None:
        pass

    def run(self, chunk: int) -> float:
        model, data = self.env.sim.model._model, self.env.sim.data._data
        elapsed = 0.0
        for state in self.states[chunk * HORIZON : (chunk + 1) * HORIZON]:
            mujoco.mj_setState(model, data, state, STATE)
            t0 = time.perf_counter()
            for _ in range(self.substeps):
                mujoco.mj_step(model, data)
            elapsed += time.perf_counter() - t0
        return elapsed


def step_rates(steps: int, rounds: int) -> tuple[dict[str, list[float]], np.ndarray, list]:
    """Steps/s of each side per round (and the stream's 7-D commands and MuJoCo states); within a round the
    sides take turns chunk by chunk (one episode of :data:`HORIZON` steps each), so a change of machine load
    hits all alike."""
    ring_env = _RingEnvSide(steps)
    robosuite_step = _RawSide(ring_env.commands, fast=False)
    fast_step = _RawSide(ring_env.commands, fast=True)
    physics = _PhysicsSide(fast_step)
    sides = {"env": ring_env, "raw": robosuite_step, "fast": fast_step, "physics": physics}
    rates: dict[str, list[float]] = {name: [] for name in sides}
    for _ in range(rounds):
        seconds = dict.fromkeys(sides, 0.0)
        for side in sides.values():
            side.start_round()
        for chunk in range(steps // HORIZON):
            for name, side in sides.items():
                seconds[name] += side.run(chunk)
        for name in sides:
            rates[name].append(steps // HORIZON * HORIZON / seconds[name])
    for side in (ring_env.env, robosuite_step.env, fast_step.env, physics.env):
        side.close()
    return rates, ring_env.commands, physics.states


def substep_loops(commands: np.ndarray, states: list, steps: int) -> dict:
    """ms per control step of 25 substeps of control + physics, four ways, each from the same recorded MuJoCo
    states with the same commands (taking turns state by state):

    - ``physics``: ``mj_step`` alone (no controller; the ceiling);
    - ``robosuite_controllers``: ``sim.step1`` -> robosuite's ``robot.control`` -> ``sim.step2``: robosuite's own
      per-substep path (its Python OSC with numba's ``opspace_matrices``), without the env around it;
    - ``python_loop_compiled_law``: ``mujoco.mj_step1`` -> :meth:`FastStep.control` (the compiled law, called
      from Python) -> ``mujoco.mj_step2``;
    - ``compiled_loop``: :meth:`FastStep.run_substeps`: the whole loop in numba, MuJoCo's C functions called
      by address (what the fast step runs).
    """
    env = _raw_env()
    env.reset()
    fast, robot = FastStep(env), env.robots[0]
    model, data = env.sim.model._model, env.sim.data._data
    substeps = int(env.control_timestep / env.model_timestep)

    def physics(command: np.ndarray) -> None:
        for _ in range(substeps):
            mujoco.mj_step(model, data)

    def robosuite_controllers(command: np.ndarray) -> None:
        for k in range(substeps):
            env.sim.step1()
            robot.control(command, policy_step=k == 0)
            env.sim.step2()

    def python_loop(command: np.ndarray) -> None:
        for k in range(substeps):
            mujoco.mj_step1(model, data)
            fast.control(command, policy_step=k == 0)
            mujoco.mj_step2(model, data)

    def compiled_loop(command: np.ndarray) -> None:
        fast.run_substeps(command, substeps)

    ways = {
        "physics": physics,
        "robosuite_controllers": robosuite_controllers,
        "python_loop_compiled_law": python_loop,
        "compiled_loop": compiled_loop,
    }
    seconds = dict.fromkeys(ways, 0.0)
    for state, command in list(zip(states, commands))[:steps]:
        for name, way in ways.items():
            mujoco.mj_setState(model, data, state, STATE)
            t0 = time.perf_counter()
            way(command)
            seconds[name] += time.perf_counter() - t0
    env.close()
    count = min(steps, len(states))
    ms = {name: 1e3 * value / count for name, value in seconds.items()}
    return {
        "ms_per_control_step": {name: round(value, 3) for name, value in ms.items()},
        "speedup_vs_robosuite_controllers": {
            name: round(ms["robosuite_controllers"] / value, 2) for name, value in ms.items()
        },
        "control_steps": count,
    }


def env_fps(steps: int, num_envs: int = 1, workers: int = 0) -> float:
    """Steps/s of the TorchRL env with ``num_envs`` simulations on the random 6-D stream."""
    env = build_env(_cfg(workers), num_envs, seed=0)
    rounds = steps // num_envs
    actions = _actions(rounds * num_envs).reshape(rounds, num_envs, 6)
    td = env.reset()
    t0 = time.perf_counter()
    for t in range(rounds):
        td["action"] = actions[t]
        _, td = env.step_and_maybe_reset(td)
    fps = rounds * num_envs / (time.perf_counter() - t0)
    env.close()
    return fps


def _learner(env):
    """An untrained 5-member ensemble, the same weights every call (the learner acting alone)."""
    torch.manual_seed(0)
    return make_actor(OmegaConf.load(ROOT / "configs/modules/aperture.yaml").actor, env)


def collector_fps(episodes: int) -> tuple[float, int]:
    env = build_env(_cfg(0), 1, seed=0)
    actor = _learner(env)
    collector = InterventionCollector(env, policy=actor)
    with torch.no_grad():
        t0 = time.perf_counter()
        frames = sum(
            e.record["length"] for e in collector.rollout(EpisodeBudget(episodes), "eval", 0, autonomous_policy(actor))
        )
        fps = frames / (time.perf_counter() - t0)
    env.close()
    return fps, frames


def bare_policy_loop_fps(frames: int) -> float:
    """The same policy on the same env and seed as :func:`collector_fps`, in a bare
    ``policy -> env.step_and_maybe_reset`` loop: the collector's own overhead is the difference."""
    env = build_env(_cfg(0), 1, seed=0)
    policy = autonomous_policy(_learner(env))
    with torch.no_grad():
        td = env.reset()
        t0 = time.perf_counter()
        for _ in range(frames):
            td = policy(td)
            _, td = env.step_and_maybe_reset(td)
        fps = frames / (time.perf_counter() - t0)
    env.close()
    return fps


def expert_statistics(episodes: int, workers: int = 2, fast_step: bool = True) -> dict:
    """The scripted expert alone over ``episodes`` episodes (``rows``: each episode's success and length)."""
    env = build_env(_cfg(workers, fast_step), max(1, workers), seed=4_242)
    expert = make_expert(cast(DictConfig, OmegaConf.load(ROOT / "configs/expert/scripted.yaml")), env, 4_242)
    collector = InterventionCollector(
        env, TensorDictSequential([ConstantGate(True), ExpertSwitch(expert)]), expert=expert
    )
    t0 = time.perf_counter()
    with torch.no_grad():
        rows = [e.record for e in run_episodes(collector, episodes, "demo", 0)]
    wall = time.perf_counter() - t0
    env.close()
    ok = [r["length"] for r in rows if r["success"]]
    mean = sum(ok) / max(1, len(ok))
    std = (sum((x - mean) ** 2 for x in ok) / max(1, len(ok) - 1)) ** 0.5
    return {
        "episodes": episodes,
        "success": sum(r["success"] for r in rows) / episodes,
        "episodes_with_collision": sum(r["collision"] for r in rows),
        "length_mean": round(mean, 1),
        "length_std": round(std, 1),
        "steps_per_s": round(sum(r["length"] for r in rows) / wall, 1),
        "workers": workers,
        "fast_step": fast_step,
        "rows": [(bool(r["success"]), int(r["length"])) for r in rows],
    }


def agreement(fast: dict, robosuite: dict) -> dict:
    """Do the fast step's episodes succeed as often and last as long as robosuite's (within noise)?"""
    wins = [sum(ok for ok, _ in side["rows"]) for side in (fast, robosuite)]
    counts = [len(side["rows"]) for side in (fast, robosuite)]
    lengths = [[n for ok, n in side["rows"] if ok] for side in (fast, robosuite)]
    all_lengths = [[n for _, n in side["rows"]] for side in (fast, robosuite)]
    # scipy builds its result types at import time: to the type checker their fields are unknown (cast to Any)
    _, success_p = cast(Any, stats.fisher_exact([[wins[0], counts[0] - wins[0]], [wins[1], counts[1] - wins[1]]]))
    length_p = float(cast(Any, stats.ttest_ind(lengths[0], lengths[1], equal_var=False)).pvalue)
    difference = float(np.mean(lengths[0]) - np.mean(lengths[1]))
    standard_error = float(
        np.sqrt(np.var(lengths[0], ddof=1) / len(lengths[0]) + np.var(lengths[1], ddof=1) / len(lengths[1]))
    )
    return {
        "episodes": counts,
        "successes_fast": wins[0],
        "successes_robosuite": wins[1],
        "success_p_fisher": round(float(success_p), 3),
        "length_mean_fast": round(float(np.mean(lengths[0])), 1),
        "length_mean_robosuite": round(float(np.mean(lengths[1])), 1),
        "length_mean_all_fast": round(float(np.mean(all_lengths[0])), 1),
        "length_mean_all_robosuite": round(float(np.mean(all_lengths[1])), 1),
        "length_difference": round(difference, 2),
        "length_difference_se": round(standard_error, 2),
        "length_p_welch": round(length_p, 3),
        "within_noise": bool(success_p > 0.05 and length_p > 0.05),
        # the n-th episode to end in each run (same seeds): while lengths agree, the two runs meet the same starts
        "same_success_and_length": sum(a == b for a, b in zip(fast["rows"], robosuite["rows"])),
    }


def ring_benchmarks(steps: int = 1_000, expert_episodes: int = 100, rounds: int = 5) -> dict:
    rates, commands, states = step_rates(steps, rounds)
    env_runs, raw_runs, fast_runs, physics_runs = rates["env"], rates["raw"], rates["fast"], rates["physics"]
    raw, ours = statistics.median(raw_runs), statistics.median(env_runs)

    def ratio(a: list, b: list) -> float:  # the median of the paired rounds' ratios
        return statistics.median(x / y for x, y in zip(a, b))

    env_vs_raw = ratio(env_runs, raw_runs)
    coll_runs, bare_runs = [], []
    for _ in range(3):
        fps, frames = collector_fps(5)
        coll_runs.append(fps)
        bare_runs.append(bare_policy_loop_fps(frames))
    coll, bare = max(coll_runs), max(bare_runs)
    collector_vs_bare = statistics.median(c / b for c, b in zip(coll_runs, bare_runs))
    two_local = env_fps(steps, num_envs=2, workers=0)
    two_workers = env_fps(steps, num_envs=2, workers=2)
    fast_expert = expert_statistics(expert_episodes, fast_step=True)
    robosuite_expert = expert_statistics(expert_episodes, fast_step=False)
    return {
        "raw_robosuite_fps": round(raw, 1),
        "ring_env_fps": round(ours, 1),
        "env_vs_raw": round(env_vs_raw, 3),
        "env_vs_raw_rounds": [round(e / r, 3) for e, r in zip(env_runs, raw_runs)],
        "fast_step": {
            "fast_step_fps": round(statistics.median(fast_runs), 1),
            "robosuite_step_fps": round(raw, 1),
            "physics_fps": round(statistics.median(physics_runs), 1),
            "fast_vs_robosuite": round(ratio(fast_runs, raw_runs), 3),
            "fast_vs_robosuite_rounds": [round(f / r, 3) for f, r in zip(fast_runs, raw_runs)],
            "fast_vs_physics": round(ratio(fast_runs, physics_runs), 3),
            "env_vs_physics": round(ratio(env_runs, physics_runs), 3),
            "robosuite_vs_physics": round(ratio(raw_runs, physics_runs), 3),
            "substep_loops": substep_loops(commands, states, steps),
        },
        "collector_fps": round(coll, 1),
        "collector_frames": frames,
        "bare_policy_loop_fps": round(bare, 1),
        "collector_vs_bare_loop": round(collector_vs_bare, 3),
        "collector_vs_raw": round(env_vs_raw * collector_vs_bare, 3),
        "two_envs_in_process_fps": round(two_local, 1),
        "two_envs_two_workers_fps": round(two_workers, 1),
        "workers_speedup": round(two_workers / two_local, 3),
        "scripted_expert_ring": {k: v for k, v in fast_expert.items() if k != "rows"},
        "scripted_expert_ring_robosuite_step": {k: v for k, v in robosuite_expert.items() if k != "rows"},
        "fast_step_agreement": agreement(fast_expert, robosuite_expert),
    }
