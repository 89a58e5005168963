"""The run-directory contract: ``episodes.jsonl``, ``metrics.jsonl``, ``summary.json``.

Both metrics and summary are computed from the episode rows (:mod:`dpiil_rl.records.metrics`), so
anyone can recompute them from ``episodes.jsonl``.
"""

from __future__ import annotations

import gzip
import json
import math
import os
from pathlib import Path
from typing import Any, Iterable

from dpiil_rl.records.appends import DamagedRecord, recover_jsonl, trim_csv_log


def clean_json(value: Any) -> Any:
    if isinstance(value, float) and (math.isnan(value) or math.isinf(value)):
        return None
    if isinstance(value, dict):
        return {k: clean_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [clean_json(v) for v in value]
    return value


def read_jsonl(path: str | Path) -> list[dict[str, Any]]:
    """The rows of ``path``, or of ``path.gz`` when only the compressed copy exists (archived records,
    :mod:`dpiil_rl.study.archive`); ``[]`` when neither exists."""
    path = Path(path)
    packed = path.with_name(path.name + ".gz")
    if not path.exists() and packed.exists():
        with gzip.open(packed, "rt", encoding="utf-8") as f:
            return [json.loads(line) for line in f if line.strip()]
    if not path.exists():
        return []
    with path.open() as f:
        return [json.loads(line) for line in f if line.strip()]


class RunFiles:
    """Appends rows as they happen (flushed at once: a crash loses nothing already written)."""

    def __init__(self, run_dir: str | Path) -> None:
        self.run_dir = Path(run_dir)
        self.run_dir.mkdir(parents=True, exist_ok=True)
        self.episodes_path = self.run_dir / "episodes.jsonl"
        self.metrics_path = self.run_dir / "metrics.jsonl"
        self.summary_path = self.run_dir / "summary.json"
        self.paths_path = self.run_dir / "paths.jsonl"
        # a torn last line (a crash or a full disk in the middle of a write) is dropped here; the run then goes
        # back to its checkpoint's row counts (truncate)
        self.episodes: list[dict[str, Any]] = recover_jsonl(self.episodes_path)
        self.metrics: list[dict[str, Any]] = recover_jsonl(self.metrics_path)

    def start_fresh(self) -> None:
        for path in (self.episodes_path, self.metrics_path, self.summary_path, self.paths_path):
            path.unlink(missing_ok=True)
        self.episodes, self.metrics = [], []

    def truncate(self, episodes: int, metrics: int) -> None:
        """Keep the first rows only (resume: drop what the killed iteration wrote after its checkpoint). The
        files must hold at least those rows: fewer means rows the checkpoint counts were lost."""
        for name, rows, count in (
            ("episodes.jsonl", self.episodes, episodes),
            ("metrics.jsonl", self.metrics, metrics),
        ):
            if len(rows) < int(count):
                raise DamagedRecord(
                    f"{self.run_dir / name}: {len(rows)} rows, but the checkpoint counts {count}; rows it "
                    "recorded are lost. Restore the file from a copy, or start the run over with overwrite=true."
                )
        self.episodes, self.metrics = self.episodes[:episodes], self.metrics[:metrics]
        self._rewrite(self.episodes_path, self.episodes)
        self._rewrite(self.metrics_path, self.metrics)
        kept = {r["episode"] for r in self.episodes}
        self._rewrite(self.paths_path, [r for r in recover_jsonl(self.paths_path) if r["episode"] in kept])
        for log in (self.run_dir / "csv").rglob("*.csv"):  # the CSV dashboard: steps are iterations
            trim_csv_log(log, len(self.metrics))
        self.summary_path.unlink(missing_ok=True)

    def add_episode(self, record: dict[str, Any]) -> None:
        self.episodes.append(record)
        self._append(self.episodes_path, record)

    def add_path(self, row: dict[str, Any]) -> None:
        """One episode's path (``episode``, ``phase``, ``iteration``, ``positions``, ``expert_mode``, ``risk`` and,
        on staged tasks, ``stage``: the index of every step's stage)."""
        self._append(self.paths_path, row)

    def read_paths(self) -> list[dict[str, Any]]:
        return read_jsonl(self.paths_path)

    def add_metrics(self, row: dict[str, Any]) -> None:
        self.metrics.append(row)
        self._append(self.metrics_path, row)

    def write_summary(self, summary: dict[str, Any]) -> None:
        tmp = self.summary_path.with_suffix(".json.tmp")
        tmp.write_text(json.dumps(clean_json(summary), indent=2) + "\n")
        os.replace(tmp, self.summary_path)

    @staticmethod
    def _append(path: Path, row: dict[str, Any]) -> None:
        with path.open("a") as f:
            f.write(json.dumps(clean_json(row)) + "\n")
            f.flush()

    @staticmethod
    def _rewrite(path: Path, rows: Iterable[dict[str, Any]]) -> None:
        tmp = path.with_suffix(".jsonl.tmp")
        with tmp.open("w") as f:
            for row in rows:
                f.write(json.dumps(clean_json(row)) + "\n")
        os.replace(tmp, path)
