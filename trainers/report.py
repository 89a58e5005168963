"""Tabulate finished runs: ``python trainers/report.py runs=runs/paper_protocol`` (or ``make report``).

Reads every ``summary.json`` under ``runs`` and writes ``results.md`` and ``results.csv`` there.
"""

from __future__ import annotations

import sys
from pathlib import Path

import hydra
from omegaconf import DictConfig

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from dpiil_rl.records.aggregate import aggregate, collect_summaries, write_tables  # noqa: E402
from dpiil_rl.utils.cli import report_user_errors  # noqa: E402


@hydra.main(config_path="../configs", config_name="report", version_base="1.3")
@report_user_errors
def main(cfg: DictConfig) -> None:
    rows = aggregate(collect_summaries(cfg.runs))
    if not rows:
        raise FileNotFoundError(f"runs = {cfg.runs!r}: no summary.json below it (expected finished runs)")
    md, csv_path = write_tables(rows, cfg.runs)
    print(md.read_text())
    print(f"wrote {md} and {csv_path}")


if __name__ == "__main__":
    main()
