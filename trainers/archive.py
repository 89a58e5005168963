"""Archive a study's records: ``python trainers/archive.py runs=runs/paper/aperture out=docs/results/paper_aperture``.

Keeps, per finished run, ``summary.json``, ``metrics.jsonl``, ``.hydra/config.yaml`` and ``episodes.jsonl.gz``
(what ``make report RUNS=<out>`` recomputes every table from); buffers and checkpoints stay behind.
"""

from __future__ import annotations

import sys
from pathlib import Path

import hydra
from omegaconf import DictConfig, OmegaConf

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from dpiil_rl.records.archive import archive_study  # noqa: E402
from dpiil_rl.utils.cli import report_user_errors  # noqa: E402


@hydra.main(config_path="../configs", config_name="archive", version_base="1.3")
@report_user_errors
def main(cfg: DictConfig) -> None:
    for key in ("runs", "out"):
        if OmegaConf.is_missing(cfg, key):
            raise ValueError(f"{key}: not given; expected runs=<directory of finished runs> out=<archive directory>")
    done = archive_study(cfg.runs, cfg.out, paths=bool(cfg.paths))
    print(f"archived {len(done)} runs' records from {cfg.runs} into {cfg.out}")


if __name__ == "__main__":
    main()
