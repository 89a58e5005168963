"""Load a study: every finished run under one or more root directories, with its numbers recomputed.

A run directory (``runs/<study>/<env>/<run_name>/seed_<s>/``, made by ``dpiil-train``) is finished
once it has ``summary.json``. Its summary and per-iteration curve are recomputed here from
``episodes.jsonl`` (:mod:`dpiil_rl.records.metrics`); a recorded number that disagrees with its
recomputation is an error naming the run and the field, so a report never shows a number the episode
rows do not support.
"""

from __future__ import annotations

import json
import math
import sys
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any, Iterable, Sequence

import yaml
from omegaconf import DictConfig, OmegaConf

from dpiil_rl.records.metrics import Row, iteration_metrics, run_summary
from dpiil_rl.records.run_files import read_jsonl

#: methods of the paper's study, in the order of its figures and tables, then this library's extra
#: baselines (unknown methods come after, by name)
METHOD_ORDER = (
    "bc",
    "dagger",
    "ensemble_dagger",
    "thrifty_dagger",
    "hg_dagger",
    "dpiil_mu",
    "dpiil_ucb",
    "safe_dagger",
    "lazy_dagger",
    "dagger_1step",
    "dagger_beta",
    "ensemble_dagger_menda",
    "thrifty_dagger_authors",
)
#: summary fields recomputed from episodes.jsonl and checked against summary.json
CHECKED_SUMMARY_FIELDS = (
    "interactive_success",
    "autonomous_success",
    "expert_actions",
    "interventions",
    "collisions",
    "interactive_episodes",
    "final_iteration",
)
#: metrics.jsonl fields recomputed from episodes.jsonl and checked, per iteration
CHECKED_METRIC_FIELDS = ("expert_actions", "interactive_success", "autonomous_success", "interventions", "collisions")
_TOLERANCE = 1e-9  # float rounding allowed between a recorded and a recomputed number


@dataclass
class StudyRun:
    """One finished run: identity, resolved config, raw rows and numbers recomputed from its episodes."""

    run_dir: Path
    env: str
    method: str
    seed: int
    study: str
    run_name: str
    chi_fixed: float | None  # χ of a sensitivity run (fixed threshold), None for a calibrated-χ run
    config_data: dict[str, Any]  # the resolved config as plain data (``select`` reads it)
    metrics: list[Row]  # metrics.jsonl rows as written
    episodes: list[Row]  # episodes.jsonl rows
    recorded: Row  # summary.json as written
    summary: Row = field(default_factory=dict)  # run_summary(episodes): what reports use
    curve: list[Row] = field(default_factory=list)  # iteration_metrics(episodes, k) for each k of metrics.jsonl

    @cached_property
    def config(self) -> DictConfig:
        """The resolved config as an OmegaConf node, built on first use (a study of hundreds of runs reads
        its configs as plain data: building every node took two thirds of loading a study)."""
        return OmegaConf.create(self.config_data)

    @property
    def is_sensitivity(self) -> bool:
        return self.chi_fixed is not None

    def paths(self) -> list[Row]:
        """``paths.jsonl`` rows (read on demand: they are the largest file of a run)."""
        return read_jsonl(self.run_dir / "paths.jsonl")


def _order_key(name: str) -> tuple[int, str, float, str]:
    """Known methods in the paper's order, their variants (``<method>-<label><value>``, a frontier run) after
    each by value, unknown names alphabetically at the end."""
    base, _, rest = name.partition("-")
    rank = METHOD_ORDER.index(base) if base in METHOD_ORDER else len(METHOD_ORDER)
    digits = "".join(c for c in rest if c.isdigit() or c in ".e-")
    try:
        value = float(digits) if digits else -math.inf
    except ValueError:
        value = -math.inf
    return (rank, base if rank == len(METHOD_ORDER) else "", value, rest)


def method_order(methods: Iterable[str]) -> list[str]:
    """The paper's order for known methods (each followed by its knob variants), then unknown ones alphabetically."""
    return sorted(set(methods), key=_order_key)


def find_run_dirs(roots: Sequence[str | Path]) -> tuple[list[Path], list[Path]]:
    """``(finished, unfinished)`` run directories below ``roots`` (a run directory has ``.hydra/config.yaml``)."""
    finished: set[Path] = set()
    unfinished: set[Path] = set()
    for root in roots:
        root = Path(root)
        if not root.is_dir():
            raise FileNotFoundError(
                f"runs = {str(root)!r}: no such directory (expected a directory of run directories)"
            )
        for cfg_path in root.rglob(".hydra/config.yaml"):
            run_dir = cfg_path.parent.parent.resolve()
            (finished if (run_dir / "summary.json").exists() else unfinished).add(run_dir)
        for summary_path in root.rglob("summary.json"):
            finished.add(summary_path.parent.resolve())
    return sorted(finished), sorted(unfinished - finished)


def select(data: dict[str, Any], key: str, default: Any = None) -> Any:
    """The value at the dotted ``key`` (``"method.threshold.quantile"``) of a run's plain config data, or
    ``default`` where a part of the path is missing; an interpolation (``${method.name}``) is resolved as
    :func:`OmegaConf.select` resolves it."""
    node: Any = data
    for part in key.split("."):
        if not isinstance(node, dict) or part not in node:
            return default
        node = node[part]
    if isinstance(node, str) and "${" in node:
        return OmegaConf.select(OmegaConf.create(data), key, default=default)
    return node


def read_config(path: Path) -> dict[str, Any]:
    """A run's resolved ``.hydra/config.yaml`` as plain data (libyaml's loader where it is built)."""
    loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
    data = yaml.load(path.read_text(), Loader=loader) if path.exists() else None
    return data if isinstance(data, dict) else {}


def chi_from_config(config: dict[str, Any]) -> float | None:
    """The fixed χ of a run whose threshold rule is ``FixedThreshold``, else None."""
    threshold = select(config, "method.threshold")
    if not isinstance(threshold, dict) or not str(threshold.get("_target_", "")).endswith("FixedThreshold"):
        return None
    return float(threshold["value"])


def _same(recorded: Any, recomputed: Any) -> bool:
    if recorded is None or recomputed is None:
        return recorded is None and recomputed is None
    return math.isclose(float(recorded), float(recomputed), rel_tol=_TOLERANCE, abs_tol=_TOLERANCE)


def _mismatch(run_dir: Path, where: str, key: str, recorded: Any, recomputed: Any) -> ValueError:
    return ValueError(
        f"run {str(run_dir)!r}: {where} {key} = {recorded!r} but episodes.jsonl gives {recomputed!r} "
        f"(expected the recorded number to recompute from the episode rows)"
    )


def load_run(run_dir: str | Path) -> StudyRun:
    """Read one finished run and recompute its summary and curve; raise ``ValueError`` on a mismatch."""
    run_dir = Path(run_dir)
    summary_path = run_dir / "summary.json"
    if not summary_path.exists():
        raise FileNotFoundError(f"run {str(run_dir)!r}: no summary.json (expected a finished run)")
    recorded = json.loads(summary_path.read_text())
    cfg_path = run_dir / ".hydra" / "config.yaml"
    config = read_config(cfg_path)
    episodes = read_jsonl(run_dir / "episodes.jsonl")
    metrics = read_jsonl(run_dir / "metrics.jsonl")
    summary = run_summary(episodes)
    for key in CHECKED_SUMMARY_FIELDS:
        if key in recorded and not _same(recorded[key], summary[key]):
            raise _mismatch(run_dir, "summary.json", key, recorded[key], summary[key])
    curve = [iteration_metrics(episodes, int(row["iteration"])) for row in metrics]
    for row, recomputed in zip(metrics, curve):
        for key in CHECKED_METRIC_FIELDS:
            if key in row and not _same(row[key], recomputed[key]):
                raise _mismatch(run_dir, f"metrics.jsonl iteration {row['iteration']}", key, row[key], recomputed[key])
    # a sensitivity run is one whose χ was fixed by ``chi=`` (a method whose own rule is a fixed value,
    # SafeDAgger's P > 0.5, is not); records without a config fall back to their summary
    chi = select(config, "chi") if "chi" in config else recorded.get("chi_fixed", chi_from_config(config))
    return StudyRun(
        run_dir=run_dir,
        env=str(recorded.get("env", select(config, "env.name"))),
        method=str(recorded.get("method", select(config, "method.name"))),
        seed=int(recorded.get("seed", select(config, "seed"))),
        study=str(recorded.get("study", select(config, "study", default=""))),
        run_name=str(recorded.get("run_name", run_dir.parent.name)),
        chi_fixed=None if chi is None else float(chi),
        config_data=config,
        metrics=metrics,
        episodes=episodes,
        recorded=recorded,
        summary=summary,
        curve=curve,
    )


def dataset_mismatches(runs: Sequence[StudyRun]) -> list[str]:
    """A note per run whose dataset D (``dataset_size`` of ``metrics.jsonl``) does not hold exactly the expert
    pairs its episodes record (``expert_actions``) while the buffer is below capacity. Since fabaadf they
    always agree; before it, a run paused with two or more envs kept the labelled frames of episodes the
    pause cut short (valid expert labels of unrecorded episodes)."""
    notes = []
    for run in runs:
        capacity = select(run.config_data, "buffer.capacity")
        rows = [
            r
            for r in run.metrics
            if r.get("dataset_size") is not None
            and r.get("expert_actions") is not None
            and (capacity is None or r["dataset_size"] < int(capacity))
        ]
        off = [r for r in rows if int(r["dataset_size"]) != int(r["expert_actions"])]
        if off:
            last = rows[-1]
            notes.append(
                f"{run.env}/{run.run_name}/seed_{run.seed}: its dataset holds "
                f"{int(last['dataset_size']) - int(last['expert_actions']):+d} "
                f"pairs beside the {int(last['expert_actions']):,} its episodes record "
                f"(from iteration {off[0]['iteration']}: "
                "frames of an episode a pause cut short)"
            )
    return notes


def load_study(roots: str | Path | Sequence[str | Path]) -> list[StudyRun]:
    """Every finished run below ``roots``; unfinished ones are skipped with one warning line on stderr.

    Two different directories holding the same (env, method, seed, χ) run are an error: the study
    would count that seed twice.
    """
    roots = [roots] if isinstance(roots, (str, Path)) else list(roots)
    finished, unfinished = find_run_dirs(roots)
    if unfinished:
        print(
            f"warning: skipping {len(unfinished)} unfinished run(s) (no summary.json): "
            + ", ".join(str(p) for p in unfinished),
            file=sys.stderr,
        )
    runs = [load_run(p) for p in finished]
    seen: dict[tuple[str, str, str, int, float | None], Path] = {}
    for run in runs:
        key = (run.env, run.method, run.run_name, run.seed, run.chi_fixed)
        if key in seen:
            raise ValueError(
                f"runs: {str(seen[key])!r} and {str(run.run_dir)!r} are the same run "
                f"(env {run.env}, method {run.method}, run {run.run_name}, seed {run.seed}, χ {run.chi_fixed}); "
                "expected each seed once per study"
            )
        seen[key] = run.run_dir
    return runs
