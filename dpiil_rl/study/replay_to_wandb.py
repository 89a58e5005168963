"""Give finished runs a wandb dashboard after the fact: ``make dashboard RUNS=<dir>``.

Runs that logged to CSV or to nothing (the ring study logs to CSV; ``logger=none`` smoke runs), or whose
records were copied elsewhere (``docs/results/...`` keeps a run's records without its ``wandb/``), still
have everything a dashboard shows: the resolved config, ``metrics.jsonl``, ``episodes.jsonl``,
``summary.json`` and ``plots/``. This writes them into an offline wandb run under the run directory —
the same group (study), job type (method), run name, namespaced per-iteration metrics, episode table,
summary and images that a run with ``logger=wandb`` writes while it trains — so ``wandb sync`` (``make
sync``) uploads it like any other. Runs that already have an offline wandb run are left alone unless
``force``. Without ``plots/`` (copied records) the learning curve is drawn from ``metrics.jsonl`` into the
new run's folder.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence, cast

from omegaconf import OmegaConf

from dpiil_rl.loggers.dashboard_keys import dashboard_row
from dpiil_rl.loggers.run_logger import make_wandb_logger, run_display_name
from dpiil_rl.loggers.wandb_offline import offline_runs
from dpiil_rl.study.study_runs import StudyRun, load_study

#: marks a dashboard run written from records (in its summary), so it is never mistaken for a live log
REPLAYED_KEY = "replayed_from_records"


@dataclass
class Replayed:
    run_dir: Path
    offline_run: Path | None  # the new offline-run-* folder (None: skipped)
    note: str = ""


def _images(run: StudyRun, scratch: Path) -> dict[str, Path]:
    """``plots/<name>`` → PNG: the run's own plots, else a learning curve drawn from its metrics."""
    plots = sorted((run.run_dir / "plots").glob("*.png"))
    if plots:
        return {f"plots/{p.stem}": p for p in plots}
    from dpiil_rl.plots.learning_curve import plot_learning_curve  # noqa: PLC0415 (matplotlib only when needed)

    scratch.mkdir(parents=True, exist_ok=True)
    title = f"{run.env} · {run.method} · seed {run.seed}"
    return {"plots/learning_curve": plot_learning_curve(run.metrics, scratch / "learning_curve.png", title)}


def replay_run(run: StudyRun, project: str = "dpiil_rl", force: bool = False) -> Replayed:
    """Write one finished run's records into a new offline wandb run under ``<run_dir>/wandb``."""
    wandb_dir = run.run_dir / "wandb"
    before = set(offline_runs(wandb_dir)) if wandb_dir.is_dir() else set()
    if before and not force:
        return Replayed(run.run_dir, None, f"has a wandb run already ({min(before).name}); force=true adds another")
    config = cast("dict[str, Any]", OmegaConf.to_container(run.config, resolve=True))  # a mapping's container
    assert isinstance(config, dict)
    logger = make_wandb_logger(
        str(run.run_dir),
        run_display_name(run.env, run.run_name, run.seed),
        run.study,
        run.method,
        config,
        project=project,
        mode="offline",
    )
    try:
        for row in run.metrics:
            logger.log_metrics(dashboard_row(row), step=int(row["iteration"]))
        for name, path in _images(run, wandb_dir / "replay_plots").items():
            logger.log_image(name, path)
        logger.log_table("episodes", list(run.episodes))
        logger.log_summary({**run.recorded, REPLAYED_KEY: True})
    finally:
        logger.close()
    new = sorted(set(offline_runs(wandb_dir)) - before)
    return Replayed(run.run_dir, new[0] if new else None, "" if new else "wandb wrote no offline run")


def replay_runs(roots: Sequence[str | Path], project: str = "dpiil_rl", force: bool = False) -> list[Replayed]:
    """:func:`replay_run` for every finished run below ``roots`` (unfinished ones are named and skipped)."""
    runs = load_study(list(roots))
    if not runs:
        raise FileNotFoundError(
            f"runs = {[str(r) for r in roots]}: no finished run below it (expected run directories with summary.json)"
        )
    return [replay_run(run, project, force) for run in runs]


def replay_markdown(results: Sequence[Replayed]) -> str:
    """One line per run: where its dashboard run is, or why it was skipped."""
    lines = []
    for r in results:
        lines.append(
            f"{r.run_dir}: {r.offline_run.name if r.offline_run else 'skipped'}" + (f" ({r.note})" if r.note else "")
        )
    made = sum(r.offline_run is not None for r in results)
    lines.append(
        f"{made} offline wandb run(s) written; upload them with `make sync RUNS=<dir>` where a server is reachable"
    )
    return "\n".join(lines)
