"""Ring-task benchmarks (``make bench``): our env and collector vs raw robosuite, workers, the expert.

- ``raw_robosuite_fps``: robosuite's ``NutAssemblyRound`` stepped directly (random 7-D actions).
- ``env_fps``: the same through :class:`~dpiil_rl.envs.ring.RingEnv` (TorchRL, 6-D actions, collision
  flags, horizon), one simulation in this process.
- ``collector_fps``: whole episodes through :class:`InterventionCollector` with the learner's policy
  (an untrained 5-member ensemble acting alone), the loop the evaluation runs.
- ``workers_fps``: two simulations stepped by two worker processes vs one in this process.
- ``expert_statistics``: the scripted expert alone over N episodes (success, length, collisions).
"""

from __future__ import annotations

import logging
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

ROOT = Path(__file__).resolve().parents[1]


def _cfg(workers: int = 0):
    cfg = OmegaConf.load(ROOT / "configs/env/ring.yaml")
    cfg.workers = workers
    return cfg


def raw_robosuite_fps(steps: int) -> float:
    import robosuite
    from robosuite.controllers import load_composite_controller_config

    logging.getLogger("robosuite").setLevel(logging.ERROR)
    env = robosuite.make("NutAssemblyRound", robots="UR5e",
                         controller_configs=load_composite_controller_config(controller="BASIC", robot="UR5e"),
                         has_renderer=False, has_offscreen_renderer=False, use_camera_obs=False, ignore_done=True,
                         hard_reset=False, horizon=10_000, control_freq=20, reward_shaping=False, seed=0)
    rng = np.random.default_rng(0)
    env.reset()
    t0 = time.perf_counter()
    for t in range(steps):
        env.step(rng.uniform(-0.3, 0.3, 7))
        if (t + 1) % 200 == 0:
            env.reset()
    fps = steps / (time.perf_counter() - t0)
    env.close()
    return fps


def env_fps(steps: int, num_envs: int = 1, workers: int = 0) -> float:
    env = build_env(_cfg(workers), num_envs, seed=0)
    gen = torch.Generator().manual_seed(0)
    td = env.reset()
    t0 = time.perf_counter()
    for _ in range(steps // num_envs):
        td["action"] = (torch.rand(num_envs, 6, generator=gen) * 2 - 1) * 0.3
        _, td = env.step_and_maybe_reset(td)
    fps = (steps // num_envs) * num_envs / (time.perf_counter() - t0)
    env.close()
    return fps


def collector_fps(episodes: int) -> tuple[float, int]:
    env = build_env(_cfg(0), 1, seed=0)
    actor = make_actor(OmegaConf.load(ROOT / "configs/modules/aperture.yaml").actor, env)
    collector = InterventionCollector(env, policy=actor)
    with torch.no_grad():
        t0 = time.perf_counter()
        frames = sum(e.record["length"] for e in collector.rollout(EpisodeBudget(episodes), "eval", 0, autonomous_policy(actor)))
        fps = frames / (time.perf_counter() - t0)
    env.close()
    return fps, frames


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


def ring_benchmarks(steps: int = 1_000, expert_episodes: int = 100) -> dict:
    raw = max(raw_robosuite_fps(steps) for _ in range(2))
    ours = max(env_fps(steps) for _ in range(2))
    coll, frames = max(collector_fps(5) for _ in range(2))
    two_local = env_fps(steps, num_envs=2, workers=0)
    two_workers = env_fps(steps, num_envs=2, workers=2)
    return {
        "raw_robosuite_fps": round(raw, 1),
        "ring_env_fps": round(ours, 1),
        "env_vs_raw": round(ours / raw, 3),
        "collector_fps": round(coll, 1),
        "collector_frames": frames,
        "collector_vs_raw": round(coll / raw, 3),
        "two_envs_in_process_fps": round(two_local, 1),
        "two_envs_two_workers_fps": round(two_workers, 1),
        "workers_speedup": round(two_workers / two_local, 3),
        "scripted_expert_ring": expert_statistics(expert_episodes),
    }
