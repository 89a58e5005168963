"""Synthetic finished run directories for report tests: summary.json, metrics.jsonl, episodes.jsonl,
paths.jsonl and .hydra/config.yaml, consistent with each other (metrics and summary computed from the
episode rows exactly as the trainer does)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Sequence

from omegaconf import OmegaConf

from dpiil_rl.records.metrics import iteration_metrics, run_summary


def _successes(rate: float, n: int) -> list[bool]:
    k = round(rate * n)
    return [True] * k + [False] * (n - k)


def write_run(
    root: Path,
    method: str,
    seed: int,
    interactive: Sequence[float] | None,
    autonomous: Sequence[float],
    env: str = "aperture",
    study: str = "synthetic",
    chi_fixed: float | None = None,
    n_interactive: int = 10,
    n_eval: int = 20,
    expert_steps: int = 20,
    demo_steps: int = 80,
    run_name: str | None = None,
    chi_in_summary: bool = True,
) -> Path:
    """A finished run with K = len(autonomous) - 1 iterations.

    ``interactive[k-1]``: success rate of iteration k's ``n_interactive`` interactive episodes (None: a
    non-interactive method such as BC, whose later pairs are plain demos). ``autonomous[k]``: success rate
    of iteration k's ``n_eval`` evaluation episodes.
    """
    run_name = run_name or (method if chi_fixed is None else f"{method}_chi{chi_fixed:g}")
    run_dir = root / study / env / run_name / f"seed_{seed}"
    (run_dir / ".hydra").mkdir(parents=True)
    episodes: list[dict[str, Any]] = []
    paths: list[dict[str, Any]] = []

    def add(phase: str, iteration: int, success: bool, steps: int, length: int) -> None:
        n = len(episodes)
        episodes.append(
            {
                "phase": phase,
                "iteration": iteration,
                "episode": n,
                "success": success,
                "collision": not success,
                "out_of_bounds": False,
                "timeout": False,
                "length": length,
                "expert_steps": steps,
                "interventions": 1 if steps else 0,
                "start": [5.0, 3.0],
            }
        )
        if phase != "eval":
            positions = [[5.0 + 0.1 * t, 3.0 + 0.1 * t] for t in range(length + 1)]
            expert = [phase == "demo" or t < steps for t in range(length)]
            paths.append(
                {
                    "episode": n,
                    "phase": phase,
                    "iteration": iteration,
                    "positions": positions,
                    "expert_mode": expert,
                    "risk": [0.0] * length,
                }
            )

    for _ in range(3):
        add("demo", 0, True, demo_steps, demo_steps)
    for k, rate in enumerate(autonomous):
        if k > 0:
            if interactive is None:
                add("demo", k, True, expert_steps * n_interactive, expert_steps * n_interactive)
            else:
                for ok in _successes(interactive[k - 1], n_interactive):
                    add("interactive", k, ok, expert_steps, 60)
        for ok in _successes(rate, n_eval):
            add("eval", k, ok, 0, 50)

    metrics = [
        {**iteration_metrics(episodes, k), "chi": chi_fixed if chi_fixed is not None else 1e-3}
        for k in range(len(autonomous))
    ]
    summary = {
        "env": env,
        "method": method,
        "seed": seed,
        "study": study,
        "run_name": run_name,
        **run_summary(episodes),
        "wall_time_s": 1.0,
    }
    if chi_in_summary:
        summary["chi_fixed"] = chi_fixed
    threshold = (
        {"_target_": "dpiil_rl.modules.threshold.FixedThreshold", "value": chi_fixed}
        if chi_fixed is not None
        else {"_target_": "dpiil_rl.modules.threshold.QuantileThreshold", "quantile": 0.8}
    )
    config = {"env": {"name": env}, "method": {"name": method, "threshold": threshold}, "seed": seed, "study": study}
    OmegaConf.save(OmegaConf.create(config), run_dir / ".hydra" / "config.yaml")
    for name, rows in (("episodes.jsonl", episodes), ("metrics.jsonl", metrics), ("paths.jsonl", paths)):
        (run_dir / name).write_text("".join(json.dumps(r) + "\n" for r in rows))
    (run_dir / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    return run_dir


#: per-seed (interactive rate per iteration, autonomous rate per iteration) of a small two-iteration study
STUDY: dict[str, list[tuple[list[float] | None, list[float]]]] = {
    "bc": [(None, [0.2, 0.25, 0.3]), (None, [0.1, 0.2, 0.25]), (None, [0.3, 0.3, 0.35])],
    "dagger": [([0.5, 0.6], [0.2, 0.6, 0.8]), ([0.4, 0.5], [0.1, 0.5, 0.75]), ([0.6, 0.5], [0.3, 0.7, 0.8])],
    "dpiil_ucb": [([0.9, 1.0], [0.2, 0.9, 1.0]), ([1.0, 1.0], [0.1, 0.95, 1.0]), ([0.9, 0.9], [0.3, 0.9, 0.95])],
    "my_new_method": [([0.7, 0.8], [0.2, 0.7, 0.9]), ([0.8, 0.7], [0.1, 0.7, 0.85])],
}


def write_study(
    root: Path, study: dict[str, list[tuple[list[float] | None, list[float]]]] = STUDY, **kw: Any
) -> list[Path]:
    """Every (method, seed) of ``study`` under ``root``; returns the run directories."""
    return [
        write_run(root, m, s, inter, auto, **kw) for m, seeds in study.items() for s, (inter, auto) in enumerate(seeds)
    ]


def write_chi_study(root: Path, chis: Sequence[float] = (1e-5, 1e-4, 1e-3), seeds: int = 2) -> list[Path]:
    """Fixed-χ runs of ensemble_dagger and dpiil_ucb: success falls with log10 χ (dpiil_ucb exactly linearly
    in the per-χ mean, with seed noise), ensemble_dagger's interactive success constant."""
    dirs = []
    for s in range(seeds):
        for i, chi in enumerate(chis):
            noise = 0.1 * (s - (seeds - 1) / 2)
            dirs.append(
                write_run(
                    root,
                    "dpiil_ucb",
                    s,
                    [0.9 - 0.2 * i + noise] * 2,
                    [0.5, 0.9 - 0.2 * i, 0.9 - 0.2 * i - noise],
                    study="chi",
                    chi_fixed=chi,
                )
            )
            dirs.append(
                write_run(
                    root,
                    "ensemble_dagger",
                    s,
                    [0.8, 0.8],
                    [0.5, 0.7, 0.6 + 0.1 * s + 0.05 * i],
                    study="chi",
                    chi_fixed=chi,
                )
            )
    return dirs
