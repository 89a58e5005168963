"""Evaluate every run of a study on the same start states: ``make evaluate RUNS=runs/paper/ring``.

A study's own test episodes are few (10 per run on the robot tasks) and drawn per run; this re-runs
each finished run's final policy alone on ``episodes`` start states shared by all runs (one seed), so
methods are compared pairwise on identical starts with more episodes. Per run it writes what
:func:`~dpiil_rl.training.evaluation.evaluate_run` writes (``<run>/evaluations/<name>.json`` and its
``episodes.jsonl``); over the study it writes ``<out>/<name>.md`` and ``.json``: per (env, method) the
success rate mean ± std over seeds with a bootstrap 95% interval, the Welch test against the reference
method (the difference with its Welch 95% interval, p, and the seeds per method a power calculation asks
for) and, on multi-stage tasks, how far the failed episodes got (also drawn: ``<name>_stages.png``).
Runs without a checkpoint (a study's committed records hold none) are listed as not evaluated, unless their
evaluation is already saved: committed records keep it, so the table is recomputed from them.
"""

from __future__ import annotations

import json
import math
import statistics
from pathlib import Path
from types import SimpleNamespace
from typing import Any, Sequence

from tqdm import tqdm

from dpiil_rl.records.checkpoints import latest_checkpoint
from dpiil_rl.records.run_files import read_jsonl
from dpiil_rl.study.intervals import bootstrap_ci, seeds_for_power, welch_interval
from dpiil_rl.study.stage_bars import stage_bars
from dpiil_rl.study.stage_table import stage_counts, stages_markdown
from dpiil_rl.study.study_runs import load_study, method_order
from dpiil_rl.study.study_stats import welch
from dpiil_rl.training.evaluation import evaluate_run, saved_evaluation


def _mean_std(values: Sequence[float]) -> str:
    mean = 100.0 * statistics.fmean(values)
    if len(values) < 2:
        return f"{mean:.1f}% (n=1)"
    return f"{mean:.1f} ± {100.0 * statistics.stdev(values):.1f}%"


def _interval(lo: float, hi: float, scale: float = 100.0, signed: bool = False) -> str:
    if math.isnan(lo):
        return "–"
    f = "+.1f" if signed else ".1f"
    return f"[{scale * lo:{f}}, {scale * hi:{f}}]"


def study_evaluation_markdown(
    results: Sequence[dict[str, Any]],
    episodes: int,
    seed: int,
    title: str,
    reference: str = "dpiil_ucb",
    skipped: Sequence[str] = (),
) -> str:
    """The study table of :func:`evaluate_study` (``results``: its per-run result dicts; ``skipped``: the run
    directories that had no checkpoint to evaluate)."""
    lines = [
        f"# {title}",
        "",
        f"Each run's final policy alone on the same {episodes} start states (evaluation seed {seed}); "
        "success mean ± sample std over seeds with a bootstrap 95% interval, each seed's rate in brackets; "
        f"Δ = {reference} − method with the Welch 95% interval and p, and the seeds per method a two-sample "
        "t-test needs to resolve Δ (α = 0.05, power 0.8).",
        "",
        "| env | method | seeds | success | 95% CI | "
        f"Δ {reference} − method [95% CI] | p (Welch) | seeds for power 0.8 | per seed |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for r in results:
        groups.setdefault((r["env"], r["method"]), []).append(r)
    for env in sorted({e for e, _ in groups}):
        rates_of = {
            m: [r["success"] for r in sorted(groups[(env, m)], key=lambda r: r["seed"])] for e, m in groups if e == env
        }
        ref = rates_of.get(reference)
        for method in method_order(rates_of):
            rates = rates_of[method]
            if ref is None or method == reference:
                diff = p = need = "–"
            else:
                lo, hi = welch_interval(ref, rates)
                _, pv, _ = welch(ref, rates)
                n = seeds_for_power(ref, rates)
                d = 100.0 * (statistics.fmean(ref) - statistics.fmean(rates))
                diff = f"{d:+.1f} pts {_interval(lo, hi, signed=True)}"
                p = "–" if math.isnan(pv) else f"{pv:.2g}"
                need = "–" if math.isnan(n) else ("> 100,000" if math.isinf(n) else f"{int(n)}")
            lines.append(
                f"| {env} | {method} | {len(rates)} | {_mean_std(rates)} | {_interval(*bootstrap_ci(rates))} | "
                f"{diff} | {p} | {need} | " + ", ".join(f"{100 * x:.0f}%" for x in rates) + " |"
            )
    if skipped:
        lines += ["", f"Not evaluated, no checkpoint (records only): {len(skipped)} runs: " + ", ".join(skipped)]
    staged = [
        SimpleNamespace(env=r["env"], method=r["method"], episodes=r["rows"], recorded={"stages": list(r["stages"])})
        for r in results
        if r.get("stages")
    ]
    for env in sorted({s.env for s in staged}):
        env_runs = [s for s in staged if s.env == env]
        lines += ["", "## How far the episodes got", ""]
        lines += stages_markdown(
            stage_counts(env_runs, "final_eval"),
            env_runs[0].recorded["stages"],
            f"{env}: furthest stage of each episode, pooled over seeds",
        )
    return "\n".join(lines).rstrip("\n") + "\n"


def evaluate_study(
    roots: str | Path | Sequence[str | Path],
    episodes: int = 30,
    num_envs: int = 10,
    max_envs: int | None = None,
    seed: int = 12_345,
    name: str | None = None,
    out_dir: str | Path | None = None,
    fresh: bool = False,
) -> dict[str, Any]:
    """Evaluate every finished calibrated-χ run below ``roots``; write the study table; return it all.

    A run that already has this evaluation (same name, episodes and seed, of its latest checkpoint,
    all its episodes on disk) is not run again unless ``fresh``: a study can be evaluated as its runs
    finish, and an evaluation stopped part-way continues with the runs it had not reached.
    """
    roots = [roots] if isinstance(roots, (str, Path)) else list(roots)
    runs = [r for r in load_study(roots) if not r.is_sensitivity]
    if not runs:
        raise FileNotFoundError(
            f"runs = {[str(r) for r in roots]}: no finished run below it (expected run directories with summary.json)"
        )
    name = name or f"common_{int(episodes)}ep_seed{int(seed)}"

    # each run's saved evaluation, read once (None: none, or not for these settings)
    saved_of = {
        run.run_dir: None if fresh else saved_evaluation(Path(run.run_dir), name, int(episodes), int(seed))
        for run in runs
    }
    missing = {r.run_dir for r in runs if latest_checkpoint(r.run_dir) is None and saved_of[r.run_dir] is None}
    skipped = [r for r in runs if r.run_dir in missing]
    runs = [r for r in runs if r.run_dir not in missing]
    if not runs:
        raise FileNotFoundError(
            f"runs = {[str(r) for r in roots]}: none of its {len(skipped)} finished runs has a checkpoint to "
            "evaluate (expected <run>/checkpoints/; committed records hold none: train the run again)"
        )
    skipped_names = [f"{r.env}/{r.method}/seed_{r.seed}" for r in skipped]
    if skipped:
        print(f"not evaluated, no checkpoint: {', '.join(skipped_names)}", flush=True)
    results = []
    reused = 0
    for run in tqdm(runs, desc="evaluate study", unit="run"):
        saved = saved_of[run.run_dir]
        if saved is None:
            result = evaluate_run(
                run.run_dir, episodes=episodes, num_envs=num_envs, seed=seed, name=name, max_envs=max_envs
            )
            rows = read_jsonl(Path(run.run_dir) / "evaluations" / name / "episodes.jsonl")
        else:
            (result, rows), reused = saved, reused + 1
        # a run's row is its run name: the method, or a variant of it (``dpiil_ucb-no_velocity_precision``)
        results.append({**result, "env": run.env, "method": run.run_name, "seed": run.seed, "rows": rows})
    out = Path(out_dir) if out_dir is not None else Path(roots[0]) / "evaluations"
    out.mkdir(parents=True, exist_ok=True)
    text = study_evaluation_markdown(
        results, int(episodes), int(seed), f"Study evaluation: {name}", skipped=skipped_names
    )
    (out / f"{name}.md").write_text(text)
    staged = [r for r in results if r.get("stages")]
    for env in sorted({r["env"] for r in staged}):
        env_runs = [
            SimpleNamespace(env=env, method=r["method"], episodes=r["rows"], recorded={"stages": list(r["stages"])})
            for r in staged
            if r["env"] == env
        ]
        suffix = "" if len({r["env"] for r in staged}) == 1 else f"_{env}"
        stage_bars(
            {f"the same {int(episodes)} start states per run": stage_counts(env_runs, "final_eval")},
            env_runs[0].recorded["stages"],
            out / f"{name}_stages{suffix}.png",
            title=f"{env}: how far the episodes got",
        )
    (out / f"{name}.json").write_text(
        json.dumps([{k: v for k, v in r.items() if k != "rows"} for r in results], indent=2) + "\n"
    )
    return {
        "name": name,
        "out_dir": str(out),
        "runs": len(results),
        "reused": reused,
        "skipped": skipped_names,
        "markdown": text,
    }
