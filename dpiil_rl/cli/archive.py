"""Archive a study's records: ``dpiil-archive runs=runs/paper/aperture out=docs/results/paper_aperture``.

Keeps, per finished run, ``summary.json``, ``metrics.jsonl``, ``.hydra/config.yaml`` and ``episodes.jsonl.gz``
(what ``make report RUNS=<out>`` recomputes every table from); buffers and checkpoints stay behind.
"""

from __future__ import annotations

from pathlib import Path

import hydra
from omegaconf import DictConfig, OmegaConf

from dpiil_rl.study.archive import archive_study
from dpiil_rl.utils.cli import report_user_errors


@hydra.main(config_path="../configs", config_name="archive", version_base="1.3")
@report_user_errors
def run(cfg: DictConfig) -> None:
    for key in ("runs", "out"):
        if OmegaConf.is_missing(cfg, key):
            raise ValueError(f"{key}: not given; expected runs=<directory of finished runs> out=<archive directory>")
    pending: list[Path] = []
    done = archive_study(cfg.runs, cfg.out, paths=bool(cfg.paths), pending=pending)
    print(f"archived {len(done)} runs' records from {cfg.runs} into {cfg.out}")
    for run in pending:
        print(f"not archived (its final common-start test is not saved yet; run its train command again): {run}")


def main() -> None:
    """The ``dpiil-archive`` command."""
    run()


if __name__ == "__main__":
    main()
