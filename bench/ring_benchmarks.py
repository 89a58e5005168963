"""Ring-task benchmarks (``make bench``): our env and collector vs raw robosuite, the fast step, workers, the expert.

- ``raw_robosuite_fps``: robosuite's ``NutAssemblyRound`` stepped directly by its own ``env.step`` with
  exactly the 7-D commands our env sent it in the same round (the 6-D stream plus the roll hold), reset
  every 200 steps: the same motion, so the same physics cost (a different stream moved the ratio by 2 points).
- ``env_fps``: the same through :class:`~dpiil_rl.envs.ring.RingEnv` (TorchRL, 6-D actions, roll hold,
  collision flags, horizon 200, the configured step: ``sim.fast_step``), one simulation in this process.
- ``fast_step_fps``: the raw env of ``raw_robosuite_fps`` stepped by
  :class:`~dpiil_rl.envs.ring_fast_step.FastStep` on the same commands (the step alone, no TorchRL).
- ``physics_fps``: the ceiling: the same scene along the same motion with no controller, ``mj_step`` x 25
  per control step from each control step's recorded MuJoCo state (its ``ctrl`` held).
  All four are measured in alternating rounds; every ratio is the median of the rounds' ratios, so a change
  of machine load between rounds does not enter it (``env_vs_raw`` moved 0.90-0.98 from run to run with
  best-of-N of each side).
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

import mujoco
import numpy as np
import torch
from omegaconf import OmegaConf
from scipy import stats
from tensordict.nn import TensorDictSequential

from dpiil_rl.collectors.intervention import InterventionCollector, run_episodes
from dpiil_rl.collectors.stop_rules import EpisodeBudget
from dpiil_rl.envs.ring_fast_step import FastStep
from dpiil_rl.hooks.evaluate import autonomous_policy
from dpiil_rl.modules.expert_switch import ExpertSwitch
from dpiil_rl.modules.gate import ConstantGate
from dpiil_rl.training.factory import build_env, make_actor, make_expert
from dpiil_rl.utils.robosuite_import import quiet_robosuite

ROOT = Path(__file__).resolve().parents[1]


def _cfg(workers: int = 0, fast_step: bool | None = None):
    cfg = OmegaConf.load(ROOT / "configs/env/ring.yaml")
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
    return robosuite.make("NutAssemblyRound", robots=cfg.sim.robot,
                          controller_configs=load_composite_controller_config(controller=cfg.sim.controller, robot=cfg.sim.robot),
                          has_renderer=False, has_offscreen_renderer=False, use_camera_obs=False, ignore_done=True,
                          hard_reset=False, horizon=10_000, control_freq=cfg.sim.control_freq, reward_shaping=False, seed=0)


def _replay(commands: np.ndarray, fast: bool, states: list | None = None) -> float:
    """Steps/s of the raw env on the 7-D ``commands`` (reset every 200 steps, like the env's horizon), by
    robosuite's ``env.step`` or by :class:`FastStep`; ``states`` collects the MuJoCo state before each step."""
    env = _raw_env()
    step = FastStep(env).step if fast else env.step
    env.reset()
    model, data = env.sim.model._model, env.sim.data._data
    kind = mujoco.mjtState.mjSTATE_INTEGRATION
    t0 = time.perf_counter()
    for t, command in enumerate(commands):
        if states is not None:
            state = np.empty(mujoco.mj_stateSize(model, kind))
            mujoco.mj_getState(model, data, state, kind)
            states.append(state)
        step(command)
        if (t + 1) % 200 == 0:
            env.reset()
    fps = len(commands) / (time.perf_counter() - t0)
    env.close()
    return fps


def raw_robosuite_fps(commands: np.ndarray) -> float:
    """robosuite's own ``env.step`` on the 7-D ``commands``."""
    return _replay(commands, fast=False)


def fast_step_fps(commands: np.ndarray) -> float:
    """:class:`FastStep` on the 7-D ``commands`` (the same raw env)."""
    return _replay(commands, fast=True)


def physics_states(commands: np.ndarray) -> list:
    """The MuJoCo state (``mjSTATE_INTEGRATION``: qpos, qvel, ctrl, warm start, ...) before each step of the motion."""
    states: list = []
    _replay(commands, fast=True, states=states)
    return states


def physics_fps(states: list) -> float:
    """Control steps/s of the physics alone: from each recorded state, ``mj_step`` x the env's substeps with its
    ``ctrl`` held (no controller); only the stepping is timed."""
    env = _raw_env()
    env.reset()
    model, data = env.sim.model._model, env.sim.data._data
    substeps = int(env.control_timestep / env.model_timestep)
    kind = mujoco.mjtState.mjSTATE_INTEGRATION
    elapsed = 0.0
    for state in states:
        mujoco.mj_setState(model, data, state, kind)
        t0 = time.perf_counter()
        for _ in range(substeps):
            mujoco.mj_step(model, data)
        elapsed += time.perf_counter() - t0
    env.close()
    return len(states) / elapsed


def env_fps(steps: int, num_envs: int = 1, workers: int = 0, commands: list | None = None) -> float:
    """Steps/s of the TorchRL env on the random 6-D stream; with ``commands`` (one in-process
    simulation), the 7-D commands its step received are appended to it (roll hold included)."""
    env = build_env(_cfg(workers), num_envs, seed=0)
    if commands is not None:
        sim = env.sims._sims[0]  # the (in-process) simulation
        step = sim._env_step  # robosuite's env.step or the fast step, as configured

        def recording_step(action: np.ndarray):
            commands.append(np.array(action))
            return step(action)

        sim._env_step = recording_step
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
        frames = sum(e.record["length"] for e in collector.rollout(EpisodeBudget(episodes), "eval", 0, autonomous_policy(actor)))
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
    expert = make_expert(OmegaConf.load(ROOT / "configs/expert/scripted.yaml"), env, 4_242)
    collector = InterventionCollector(env, TensorDictSequential(ConstantGate(True), ExpertSwitch(expert)), expert=expert)
    t0 = time.perf_counter()
    with torch.no_grad():
        rows = [e.record for e in run_episodes(collector, episodes, "demo", 0)]
    wall = time.perf_counter() - t0
    env.close()
    ok = [r["length"] for r in rows if r["success"]]
    mean = sum(ok) / max(1, len(ok))
    std = (sum((x - mean) ** 2 for x in ok) / max(1, len(ok) - 1)) ** 0.5
    return {"episodes": episodes, "success": sum(r["success"] for r in rows) / episodes,
            "episodes_with_collision": sum(r["collision"] for r in rows), "length_mean": round(mean, 1),
            "length_std": round(std, 1), "steps_per_s": round(sum(r["length"] for r in rows) / wall, 1), "workers": workers,
            "fast_step": fast_step, "rows": [(bool(r["success"]), int(r["length"])) for r in rows]}


def agreement(fast: dict, robosuite: dict) -> dict:
    """Do the fast step's episodes succeed as often and last as long as robosuite's (within noise)?"""
    wins = [sum(ok for ok, _ in side["rows"]) for side in (fast, robosuite)]
    counts = [len(side["rows"]) for side in (fast, robosuite)]
    lengths = [[n for ok, n in side["rows"] if ok] for side in (fast, robosuite)]
    all_lengths = [[n for _, n in side["rows"]] for side in (fast, robosuite)]
    _, success_p = stats.fisher_exact([[wins[0], counts[0] - wins[0]], [wins[1], counts[1] - wins[1]]])
    length_p = float(stats.ttest_ind(lengths[0], lengths[1], equal_var=False).pvalue)
    difference = float(np.mean(lengths[0]) - np.mean(lengths[1]))
    standard_error = float(np.sqrt(np.var(lengths[0], ddof=1) / len(lengths[0]) + np.var(lengths[1], ddof=1) / len(lengths[1])))
    return {
        "episodes": counts, "successes_fast": wins[0], "successes_robosuite": wins[1], "success_p_fisher": round(float(success_p), 3),
        "length_mean_fast": round(float(np.mean(lengths[0])), 1), "length_mean_robosuite": round(float(np.mean(lengths[1])), 1),
        "length_mean_all_fast": round(float(np.mean(all_lengths[0])), 1),
        "length_mean_all_robosuite": round(float(np.mean(all_lengths[1])), 1),
        "length_difference": round(difference, 2), "length_difference_se": round(standard_error, 2),
        "length_p_welch": round(length_p, 3), "within_noise": bool(success_p > 0.05 and length_p > 0.05),
    }


def ring_benchmarks(steps: int = 1_000, expert_episodes: int = 100, rounds: int = 5) -> dict:
    raw_runs, env_runs, fast_runs, physics_runs = [], [], [], []
    states: list = []
    for _ in range(rounds):  # alternating rounds: a change of load hits every side of a round alike
        commands: list = []
        env_runs.append(env_fps(steps, commands=commands))
        stream = np.stack(commands)
        if not states:
            states = physics_states(stream)  # the same stream every round: record its states once
        raw_runs.append(raw_robosuite_fps(stream))
        fast_runs.append(fast_step_fps(stream))
        physics_runs.append(physics_fps(states))
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
