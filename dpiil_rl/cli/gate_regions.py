"""Where the gate handed control to the expert and where the robot made contact, around a point.

``dpiil-gate-regions runs=docs/results/paper_ring_real point=[0.45,0.10,0.10] offset=[0.07,0,0]``
prints a markdown table per method (:mod:`dpiil_rl.study.gate_regions`), from the runs' own
``paths.jsonl``, ``episodes.jsonl`` and ``metrics.jsonl``.
"""

from __future__ import annotations

import hydra
from omegaconf import DictConfig, OmegaConf

from dpiil_rl.study.gate_regions import gate_regions, regions_table
from dpiil_rl.study.study_runs import load_study
from dpiil_rl.utils.cli import report_user_errors, run_roots


@hydra.main(config_path="../configs", config_name="gate_regions", version_base="1.3")
@report_user_errors
def run(cfg: DictConfig) -> str:
    for key in ("runs", "point"):
        if OmegaConf.is_missing(cfg, key):
            raise ValueError(f"{key}: not given; expected {key}=... (see configs/gate_regions.yaml)")
    runs = [run for run in load_study(run_roots(cfg.runs)) if not run.is_sensitivity]
    stats = gate_regions(runs, list(cfg.point), list(cfg.offset), float(cfg.radius))
    if not stats:
        raise ValueError(f"runs = {cfg.runs}: no finished run with a paths.jsonl below it")
    table = regions_table(stats, float(cfg.radius))
    print(table)
    return table


def main() -> None:
    """The ``dpiil-gate-regions`` command."""
    run()


if __name__ == "__main__":
    main()
