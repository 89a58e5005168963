"""Archive a study's records for a results page: what recomputes its tables, nothing else.

For every finished run below ``source`` the archive keeps, under the same relative path below ``target``:
``summary.json``, ``metrics.jsonl``, ``.hydra/config.yaml`` and ``episodes.jsonl`` compressed as
``episodes.jsonl.gz`` (byte-for-byte reproducible: no timestamp in the gzip header), which
:func:`~dpiil_rl.records.run_files.read_jsonl` reads transparently. Buffers, checkpoints, paths and
logs stay behind. ``paths=True`` keeps ``paths.jsonl.gz`` too (for figures of where the gates asked).
Evaluations made after the run (``evaluations/``: the common-start results ``<name>.json`` with their
``<name>/episodes.jsonl``, and gate traces ``gate_trace_*.jsonl``) are kept too, the JSON Lines compressed.

A run writes ``summary.json`` before it tests its final policy on the protocol's common starts
(``protocol.final_eval_episodes``), so a run that is still in that test, or was stopped during it, looks
finished; it is left out (and named) until its test is saved, so an archive never holds half a test.
"""

from __future__ import annotations

import gzip
import shutil
from pathlib import Path

import yaml

from dpiil_rl.study.study_runs import find_run_dirs
from dpiil_rl.training.evaluation import saved_evaluation
from dpiil_rl.training.final_evaluation import common_start_name

KEPT = ("summary.json", "metrics.jsonl", ".hydra/config.yaml")
PACKED = ("episodes.jsonl",)


def _pack(src: Path, dst: Path) -> None:
    with src.open("rb") as f, dst.open("wb") as raw, gzip.GzipFile(filename="", mode="wb", fileobj=raw, mtime=0) as out:
        shutil.copyfileobj(f, out)


def _archive_evaluations(src: Path, dst: Path) -> None:
    if not src.is_dir():
        return
    for path in sorted(src.rglob("*")):
        if path.suffix not in (".json", ".jsonl") or not path.is_file():
            continue
        target = dst / path.relative_to(src)
        target.parent.mkdir(parents=True, exist_ok=True)
        if path.suffix == ".json":
            shutil.copyfile(path, target)
        else:
            _pack(path, target.with_name(target.name + ".gz"))


def final_test_pending(run: Path) -> str | None:
    """The name of the common-start test ``run``'s protocol asks for if it is not saved (complete) yet, else None."""
    config = run / ".hydra" / "config.yaml"
    if not config.exists():
        return None
    protocol = (yaml.safe_load(config.read_text()) or {}).get("protocol") or {}
    episodes = int(protocol.get("final_eval_episodes") or 0)
    if episodes <= 0:
        return None
    seed = int(protocol.get("final_eval_seed", 12_345))
    name = common_start_name(episodes, seed)
    return None if saved_evaluation(run, name, episodes, seed) is not None else name


def archive_study(
    source: str | Path, target: str | Path, paths: bool = False, pending: list[Path] | None = None
) -> list[Path]:
    """Copy the records of every finished run below ``source`` to ``target``; return the archived run dirs.
    Runs whose final common-start test is not saved yet are left out and appended to ``pending``."""
    source, target = Path(source).resolve(), Path(target)
    finished, _ = find_run_dirs([source])
    if not finished:
        raise FileNotFoundError(
            f"runs = {str(source)!r}: no finished run below it (expected run directories with summary.json)"
        )
    out = []
    for run in finished:
        if final_test_pending(run) is not None:
            if pending is not None:
                pending.append(run)
            continue
        dst = target / run.relative_to(source)
        (dst / ".hydra").mkdir(parents=True, exist_ok=True)
        for name in KEPT:
            if (run / name).exists():
                shutil.copyfile(run / name, dst / name)
        for name in PACKED + (("paths.jsonl",) if paths else ()):
            if (run / name).exists():
                _pack(run / name, dst / f"{name}.gz")
        _archive_evaluations(run / "evaluations", dst / "evaluations")
        out.append(dst)
    return out
