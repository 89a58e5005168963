"""``make bench``: collector overhead, the scripted experts, the ring env and its fast step vs raw robosuite, and the
wall time of the default ``make train``.

Writes ``bench/results.json`` (suites not run keep their previous numbers). Numbers are measured on the machine
that runs it; the README quotes the committed file together with the machine it came from.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import TYPE_CHECKING, cast

import torch
from omegaconf import DictConfig, OmegaConf
from tensordict.nn import TensorDictSequential

from dpiil_rl.collectors.expert_switch import ExpertSwitch
from dpiil_rl.collectors.intervention import InterventionCollector
from dpiil_rl.collectors.stop_rules import EpisodeBudget
from dpiil_rl.data.buffer import make_buffer
from dpiil_rl.training.factory import build_env, make_actor, make_expert, make_method, make_speed_head

if TYPE_CHECKING:
    from dpiil_rl.modules.gate import RiskGate

ROOT = Path(__file__).resolve().parents[1]  # the package: its configs/


def _policy(num_envs: int, seed: int = 0):
    env = build_env(cast(DictConfig, OmegaConf.load(ROOT / "configs/env/aperture.yaml")), num_envs, seed)
    modules = OmegaConf.load(ROOT / "configs/modules/aperture.yaml")
    actor, speed = make_actor(modules.actor, env), make_speed_head(modules.speed_head, env)
    gate = cast(
        "RiskGate", make_method(cast(DictConfig, OmegaConf.load(ROOT / "configs/method/dpiil_ucb.yaml"))).make_gate()
    )
    expert = make_expert(cast(DictConfig, OmegaConf.load(ROOT / "configs/expert/scripted.yaml")), env, seed)
    from tensordict import TensorDict

    probe = TensorDict({"observation": torch.rand(4096, 2) * 20}, batch_size=[4096])
    with torch.no_grad():
        gate.calibrate(speed(actor(probe)))  # an untrained ensemble: top 20% of risk over the arena
    return env, TensorDictSequential([actor, speed, gate, ExpertSwitch(expert)]), expert


def bare_loop_fps(num_envs: int, frames: int) -> float:
    env, policy, _ = _policy(num_envs)
    with torch.no_grad():
        td = env.reset()
        t0 = time.perf_counter()
        steps = frames // num_envs
        for _ in range(steps):
            td = policy(td)
            _, td = env.step_and_maybe_reset(td)
        return steps * num_envs / (time.perf_counter() - t0)


def collector_fps(num_envs: int, episodes: int) -> tuple[float, int]:
    env, policy, expert = _policy(num_envs)
    with tempfile.TemporaryDirectory() as tmp:
        collector = InterventionCollector(env, policy, expert=expert, replay_buffer=make_buffer(tmp, 100_000))
        with torch.no_grad():
            t0 = time.perf_counter()
            frames = sum(e.record["length"] for e in collector.rollout(EpisodeBudget(episodes), "interactive", 1))
            elapsed = time.perf_counter() - t0
    return frames / elapsed, frames


def collector_vs_bare(num_envs: int, episodes: int, repeats: int = 3) -> dict:
    best_c, best_b, frames = 0.0, 0.0, 0
    for _ in range(repeats):  # best of N: the least disturbed measurement of each
        fps, frames = collector_fps(num_envs, episodes)
        best_c = max(best_c, fps)
        best_b = max(best_b, bare_loop_fps(num_envs, frames))
    return {
        "num_envs": num_envs,
        "frames": frames,
        "collector_fps": round(best_c, 1),
        "bare_loop_fps": round(best_b, 1),
        "ratio": round(best_c / best_b, 3),
    }


def expert_statistics(episodes: int = 1000) -> dict:
    """Success rate and episode length of the scripted expert alone (docs/design.md, "Tasks")."""
    from dpiil_rl.collectors.intervention import run_episodes
    from dpiil_rl.modules.gate import ConstantGate

    env = build_env(cast(DictConfig, OmegaConf.load(ROOT / "configs/env/aperture.yaml")), episodes, seed=123)
    expert = make_expert(cast(DictConfig, OmegaConf.load(ROOT / "configs/expert/scripted.yaml")), env, 123)
    collector = InterventionCollector(
        env, TensorDictSequential([ConstantGate(True), ExpertSwitch(expert)]), expert=expert
    )
    with torch.no_grad():
        rows = [e.record for e in run_episodes(collector, episodes, "demo", 0)]
    ok = [r["length"] for r in rows if r["success"]]
    mean = sum(ok) / len(ok)
    std = (sum((x - mean) ** 2 for x in ok) / max(1, len(ok) - 1)) ** 0.5
    return {
        "episodes": episodes,
        "success": sum(r["success"] for r in rows) / episodes,
        "collisions": sum(r["collision"] for r in rows),
        "length_mean": round(mean, 2),
        "length_std": round(std, 2),
    }


def default_train_wall_time() -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        subprocess.run(
            [sys.executable, "-m", "dpiil_rl.cli.train", f"run_root={tmp}", "progress=false"],
            check=True,
            capture_output=True,
            text=True,
        )
        wall = time.perf_counter() - t0
        summary = json.loads(next(Path(tmp).rglob("summary.json")).read_text())
    return {
        "command": "dpiil-train (= make train once set up)",
        "wall_time_s": round(wall, 1),
        "in_loop_wall_time_s": summary["wall_time_s"],
        "interactive_success": summary["interactive_success"],
        "autonomous_success": summary["autonomous_success"],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--skip-train", action="store_true", help="skip timing the default make train")
    parser.add_argument(
        "--suites", default="aperture,fit,ring,throughput", help="comma list of: aperture, fit, ring, throughput"
    )
    parser.add_argument("--throughput-seeds", type=int, default=10, help="runs per way of the throughput bench")
    parser.add_argument("--throughput-rounds", type=int, default=2, help="alternating rounds of the throughput bench")
    parser.add_argument("--ring-expert-episodes", type=int, default=100, help="episodes of the ring expert statistic")
    parser.add_argument("--out", default="bench/results.json", help="results file (relative to where the command runs)")
    args = parser.parse_args()
    torch.set_num_threads(1)
    suites = {s.strip() for s in args.suites.split(",") if s.strip()}
    unknown = suites - {"aperture", "fit", "ring", "throughput"}
    if unknown:
        parser.error(f"--suites {sorted(unknown)}: unknown (expected some of aperture, fit, ring, throughput)")
    out = Path(args.out)
    results = json.loads(out.read_text()) if out.exists() else {}
    machine = {
        "cpu_count": os.cpu_count(),
        "platform": platform.platform(),
        "python": platform.python_version(),
        "torch": torch.__version__,
    }
    results.update({"machine": machine, "date": time.strftime("%Y-%m-%d")})  # of the latest bench run
    # each suite's own date and machine: a run of some suites leaves the others' numbers, measured earlier
    measured = results.setdefault("measured", {})
    for suite in sorted(suites | ({"default_make_train"} if not args.skip_train else set())):
        measured[suite] = {"date": results["date"], **machine}
    if "aperture" in suites:
        results["scripted_expert_aperture"] = expert_statistics()
        results["collector_vs_bare_loop"] = [collector_vs_bare(1, 20), collector_vs_bare(100, 100)]
        print(json.dumps(results["scripted_expert_aperture"]), flush=True)
        print(json.dumps(results["collector_vs_bare_loop"], indent=2), flush=True)
    if "fit" in suites:
        from dpiil_rl.bench.fit import adam_step_cost, fit_cost

        results["fit"] = {**fit_cost(), "adam_step": adam_step_cost()}
        print(json.dumps(results["fit"], indent=2), flush=True)
    if "ring" in suites:
        from dpiil_rl.bench.ring import ring_benchmarks

        results["ring"] = ring_benchmarks(expert_episodes=args.ring_expert_episodes)
        print(json.dumps(results["ring"], indent=2), flush=True)
    if "throughput" in suites:
        from dpiil_rl.bench.throughput import study_throughput

        results["study_throughput"] = study_throughput(seeds=args.throughput_seeds, rounds=args.throughput_rounds)
        print(json.dumps(results["study_throughput"]["ratio_to_one_process_per_run"], indent=2), flush=True)
    if not args.skip_train:
        results["default_make_train"] = default_train_wall_time()
        print(json.dumps(results["default_make_train"], indent=2))
    out.write_text(json.dumps(results, indent=2) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
