"""Archive a study's records for a results page: what recomputes its tables, nothing else.

For every finished run below ``source`` the archive keeps, under the same relative path below ``target``:
``summary.json``, ``metrics.jsonl``, ``.hydra/config.yaml`` and ``episodes.jsonl`` compressed as
``episodes.jsonl.gz`` (byte-for-byte reproducible: no timestamp in the gzip header), which
:func:`~dpiil_rl.records.run_files.read_jsonl` reads transparently. Buffers, checkpoints, paths and
logs stay behind. ``paths=True`` keeps ``paths.jsonl.gz`` too (for figures of where the gates asked).
Evaluations made after the run (``evaluations/``: the common-start results ``<name>.json`` with their
``<name>/episodes.jsonl``, and gate traces ``gate_trace_*.jsonl``) are kept too, the JSON Lines compressed.
"""

from __future__ import annotations

import gzip
import shutil
from pathlib import Path

from dpiil_rl.study.study_runs import find_run_dirs

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


def archive_study(source: str | Path, target: str | Path, paths: bool = False) -> list[Path]:
    """Copy the records of every finished run below ``source`` to ``target``; return the archived run dirs."""
    source, target = Path(source).resolve(), Path(target)
    finished, _ = find_run_dirs([source])
    if not finished:
        raise FileNotFoundError(
            f"runs = {str(source)!r}: no finished run below it (expected run directories with summary.json)"
        )
    out = []
    for run in finished:
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
