"""Ring-task benchmarks (``make bench``): our env and collector vs raw robosuite, workers, the expert.

- ``raw_robosuite_fps``: robosuite's ``NutAssemblyRound`` stepped directly with exactly the 7-D commands
  our env sent it in the same round (the 6-D stream plus the roll hold), reset every 200 steps: the same
  motion, so the same physics cost (a different stream moved the ratio by 2 points).
- ``env_fps``: the same through :class:`~dpiil_rl.envs.ring.RingEnv` (TorchRL, 6-D actions, roll hold,
  collision flags, horizon 200), one simulation in this process.
  The two are measured in alternating rounds; ``env_vs_raw`` is the median of the rounds' ratios, so
  a change of machine load between rounds does not enter it (it moved 0.90-0.98 from run to run with
  best-of-N of each side).
- ``collector_fps``: whole episodes through :class:`InterventionCollector` with the learner's policy
  (an untrained 5-member ensemble acting alone), the loop the evaluation runs; ``bare_policy_loop_fps``:
  the same policy, env and seed in a bare loop. The learner moves differently from the random stream
  (its physics costs differ), so ``collector_vs_raw`` = ``env_vs_raw`` x ``collector_vs_bare_loop``,
  each measured on one action stream.
- ``workers_fps``: two simulations stepped by two worker processes vs one in this process.
- ``expert_statistics``: the scripted expert alone over N episodes (success, length, collisions).
"""

from __future__ import annotations

import statistics
import time
from pathlib import Path

import numpy as np
import torch
from omegaconf import OmegaConf
from tensordict.nn import TensorDictSequential

from dpiil_rl.collectors.intervention import InterventionCollector, run_episodes
from dpiil_rl.collectors.stop_rules import EpisodeBudget
from dpiil_rl.hooks.evaluate import autonomous_policy
from dpiil_rl.modules.expert_switch import ExpertSwitch
from dpiil_rl.modules.gate import ConstantGate
from dpiil_rl.training.factory import build_env, make_actor, make_expert
from dpiil_rl.utils.robosuite_import import quiet_robosuite

ROOT = Path(__file__).resolve().parents[1]


def _cfg(workers: int = 0):
    cfg = OmegaConf.load(ROOT / "configs/env/ring.yaml")
    cfg.workers = workers
    return cfg


def _actions(steps: int) -> torch.Tensor:
    """The random 6-D action stream both loops replay (|a| <= 0.3)."""
    return (torch.rand(steps, 6, generator=torch.Generator().manual_seed(0)) * 2 - 1) * 0.3


def raw_robosuite_fps(commands: np.ndarray) -> float:
    """robosuite's own ``env.step`` on the 7-D ``commands`` (reset every 200 steps, like the env's horizon)."""
    with quiet_robosuite():
        import robosuite
        from robosuite.controllers import load_composite_controller_config

    env = robosuite.make("NutAssemblyRound", robots="UR5e",
                         controller_configs=load_composite_controller_config(controller="BASIC", robot="UR5e"),
                         has_renderer=False, has_offscreen_renderer=False, use_camera_obs=False, ignore_done=True,
                         hard_reset=False, horizon=10_000, control_freq=20, reward_shaping=False, seed=0)
    env.reset()
    t0 = time.perf_counter()
    for t, command in enumerate(commands):
        env.step(command)
        if (t + 1) % 200 == 0:
            env.reset()
    fps = len(commands) / (time.perf_counter() - t0)
    env.close()
    return fps


def env_fps(steps: int, num_envs: int = 1, workers: int = 0, commands: list | None = None) -> float:
    """Steps/s of the TorchRL env on the random 6-D stream; with ``commands`` (one in-process
    simulation), the 7-D commands robosuite received are appended to it (roll hold included)."""
    env = build_env(_cfg(workers), num_envs, seed=0)
    if commands is not None:
        sim = env.sims._sims[0].env  # the robosuite env inside the (in-process) simulation
        step = sim.step

        def recording_step(action: np.ndarray):
            commands.append(np.array(action))
            return step(action)

        sim.step = recording_step
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


def expert_statistics(episodes: int, workers: int = 2) -> dict:
    env = build_env(_cfg(workers), max(1, workers), seed=4_242)
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
            "length_std": round(std, 1), "steps_per_s": round(sum(r["length"] for r in rows) / wall, 1), "workers": workers}


def ring_benchmarks(steps: int = 1_000, expert_episodes: int = 100, rounds: int = 5) -> dict:
    raw_runs, env_runs = [], []
    for _ in range(rounds):  # alternating rounds: a change of load hits both sides of a round alike
        commands: list = []
        env_runs.append(env_fps(steps, commands=commands))
        raw_runs.append(raw_robosuite_fps(np.stack(commands)))
    raw, ours = statistics.median(raw_runs), statistics.median(env_runs)
    env_vs_raw = statistics.median(e / r for e, r in zip(env_runs, raw_runs))  # median of the paired ratios
    coll_runs, bare_runs = [], []
    for _ in range(3):
        fps, frames = collector_fps(5)
        coll_runs.append(fps)
        bare_runs.append(bare_policy_loop_fps(frames))
    coll, bare = max(coll_runs), max(bare_runs)
    collector_vs_bare = statistics.median(c / b for c, b in zip(coll_runs, bare_runs))
    two_local = env_fps(steps, num_envs=2, workers=0)
    two_workers = env_fps(steps, num_envs=2, workers=2)
    return {
        "raw_robosuite_fps": round(raw, 1),
        "ring_env_fps": round(ours, 1),
        "env_vs_raw": round(env_vs_raw, 3),
        "env_vs_raw_rounds": [round(e / r, 3) for e, r in zip(env_runs, raw_runs)],
        "collector_fps": round(coll, 1),
        "collector_frames": frames,
        "bare_policy_loop_fps": round(bare, 1),
        "collector_vs_bare_loop": round(collector_vs_bare, 3),
        "collector_vs_raw": round(env_vs_raw * collector_vs_bare, 3),
        "two_envs_in_process_fps": round(two_local, 1),
        "two_envs_two_workers_fps": round(two_workers, 1),
        "workers_speedup": round(two_workers / two_local, 3),
        "scripted_expert_ring": expert_statistics(expert_episodes),
    }
