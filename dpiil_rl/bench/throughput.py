"""Study throughput: the same study runs launched the way studies ran before and the new ways.

Every way trains the same (method, seed) runs of the paper protocol on the aperture task (8 scripted robots
side by side) into its own temporary run root, one way after the other on the same machine, in alternating
rounds. CPU time is the user + system time of the launch and every process it started
(``resource.getrusage(RUSAGE_CHILDREN)``), so it is what the study costs the machine whatever the core count;
runs per CPU-minute = runs / (CPU seconds / 60).

- ``one_process_per_run``: how ``make paper`` ran studies before: the joblib launcher, one process per run
  (two at a time), each with its offline wandb run and its figures.
- ``lockstep``: the seeds of one setting batched in one process (``hydra/launcher=lockstep``, their refits
  in one loop), with the same outputs: offline wandb and figures.
- ``lockstep_records_only``: the same, with the records and checkpoints only (``plots=false logger=none``),
  as ``make frontier`` and ``make collapse`` run their hundreds of runs.

The records of the runs are the same in every way (``tests/training/test_lockstep.py``); this measures cost.
"""

from __future__ import annotations

import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

COMMON = ("env=aperture", "study=bench", "progress=false", "protocol.interactive_envs=8", "hydra.launcher.n_jobs=2")
WAYS: dict[str, tuple[str, ...]] = {
    "one_process_per_run": ("hydra/launcher=joblib", "logger=wandb"),
    "lockstep": ("hydra/launcher=lockstep", "logger=wandb"),
    "lockstep_records_only": ("hydra/launcher=lockstep", "logger=none", "plots=false"),
}


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def time_way(way: str, method: str, seeds: int) -> dict:
    """Train ``seeds`` runs of ``method`` the given way; wall and CPU seconds, runs per CPU-minute."""
    with tempfile.TemporaryDirectory() as root:
        cmd = [
            sys.executable,
            "-m",
            "dpiil_rl.cli.train",
            "-m",
            f"method={method}",
            f"seed={','.join(str(s) for s in range(seeds))}",
            f"run_root={root}",
            *COMMON,
            *WAYS[way],
        ]
        cpu0, t0 = _children_cpu(), time.perf_counter()
        subprocess.run(cmd, check=True, capture_output=True, text=True, cwd=root)
        wall, cpu = time.perf_counter() - t0, _children_cpu() - cpu0
        finished = len(list(Path(root).rglob("summary.json")))
    if finished != seeds:
        raise RuntimeError(f"throughput bench, {way}: {finished} of {seeds} runs finished")
    return {
        "wall_s": round(wall, 1),
        "cpu_s": round(cpu, 1),
        "runs": seeds,
        "runs_per_cpu_minute": round(seeds / (cpu / 60.0), 2),
    }


def study_throughput(method: str = "dpiil_ucb", seeds: int = 10, rounds: int = 2) -> dict:
    """Each way ``rounds`` times, alternating; the ratios of runs per CPU-minute to the old way."""
    per_round: dict[str, list[dict]] = {way: [] for way in WAYS}
    for r in range(rounds):
        order = list(WAYS) if r % 2 == 0 else list(reversed(WAYS))
        for way in order:
            per_round[way].append(time_way(way, method, seeds))
            print(f"[throughput] round {r + 1}/{rounds} {way}: {per_round[way][-1]}", flush=True)
    best = {way: max(x["runs_per_cpu_minute"] for x in rows) for way, rows in per_round.items()}
    base = best["one_process_per_run"]
    return {
        "method": method,
        "seeds": seeds,
        "rounds": rounds,
        "per_round": per_round,
        "runs_per_cpu_minute": best,
        "ratio_to_one_process_per_run": {way: round(v / base, 2) for way, v in best.items()},
    }
