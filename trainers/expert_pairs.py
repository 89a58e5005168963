"""Where each method's expert pairs were collected, by stage of the ring task.

``python trainers/expert_pairs.py runs=runs/paper/ring [out=expert_pairs.md]`` prints a markdown table per
method (:mod:`dpiil_rl.records.expert_pairs`) from the runs' last checkpoints (their dataset D); with ``out``
it writes the table and draws it beside (``expert_pairs.png``: one bar per method, demos and later pairs).
"""

from __future__ import annotations

import sys
from pathlib import Path

import hydra
from omegaconf import DictConfig, OmegaConf

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from dpiil_rl.plots.stage_bars import stage_bars  # noqa: E402
from dpiil_rl.records.expert_pairs import PAIR_STAGES, PARTS, expert_pair_stages, pair_stage_counts, pair_stages_markdown  # noqa: E402
from dpiil_rl.records.study_runs import load_study  # noqa: E402
from dpiil_rl.utils.cli import comma_list_override, report_user_errors, run_roots  # noqa: E402


@hydra.main(config_path="../configs", config_name="expert_pairs", version_base="1.3")
@report_user_errors
def main(cfg: DictConfig) -> str:
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
        figure = stage_bars({f"expert pairs, {part}": pair_stage_counts(stats, part) for part in PARTS}, PAIR_STAGES,
                            Path(cfg.out).with_suffix(".png"), title="ring: where each method's expert pairs were taken",
                            xlabel="% of the method's expert pairs (stage of the state)", success_last=False)
        print(f"wrote {cfg.out} and {figure}")
    return table


if __name__ == "__main__":
    sys.argv = comma_list_override(sys.argv)
    main()
