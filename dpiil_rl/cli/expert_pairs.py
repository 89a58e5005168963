"""Where each method's expert pairs were collected, by stage of the ring task.

``dpiil-expert-pairs runs=runs/paper/ring [out=expert_pairs.md]`` prints a markdown table per
method (:mod:`dpiil_rl.study.expert_pairs`) from the runs' last checkpoints (their dataset D); with ``out``
it writes the table and draws it beside (``expert_pairs.png``: one bar per method, demos and later pairs).
"""

from __future__ import annotations

from pathlib import Path

import hydra
from omegaconf import DictConfig, OmegaConf

from dpiil_rl.study.expert_pairs import PAIR_STAGES, PARTS, expert_pair_stages, pair_stage_counts, pair_stages_markdown
from dpiil_rl.study.stage_bars import stage_bars
from dpiil_rl.study.study_runs import load_study
from dpiil_rl.utils.cli import report_user_errors, run_roots


@hydra.main(config_path="../configs", config_name="expert_pairs", version_base="1.3")
@report_user_errors
def run(cfg: DictConfig) -> str:
    if OmegaConf.is_missing(cfg, "runs"):
        raise ValueError("runs: not given; expected runs=<directory of ring runs> (see configs/expert_pairs.yaml)")
    runs = [run for run in load_study(run_roots(cfg.runs)) if not run.is_sensitivity]
    if not runs:
        raise ValueError(f"runs = {cfg.runs}: no finished run below it")
    stats = expert_pair_stages(runs, float(cfg.still))
    table = pair_stages_markdown(stats, float(cfg.still))
    print(table)
    if cfg.out is not None:
        Path(cfg.out).parent.mkdir(parents=True, exist_ok=True)
        Path(cfg.out).write_text(table)
        figure = stage_bars(
            {f"expert pairs, {part}": pair_stage_counts(stats, part) for part in PARTS},
            PAIR_STAGES,
            Path(cfg.out).with_suffix(".png"),
            title="ring: where each method's expert pairs were taken",
            xlabel="% of the method's expert pairs (stage of the state)",
            success_last=False,
        )
        print(f"wrote {cfg.out} and {figure}")
    return table


def main() -> None:
    """The ``dpiil-expert-pairs`` command."""
    run()


if __name__ == "__main__":
    main()
