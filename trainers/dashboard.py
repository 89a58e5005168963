"""Offline wandb runs from finished runs' records: ``python trainers/dashboard.py runs=runs/paper/ring``
(or ``make dashboard RUNS=...``).

For runs that logged to CSV or nothing, or whose records were copied without their ``wandb/`` folder
(:mod:`dpiil_rl.loggers.replay_to_wandb`). ``make sync RUNS=...`` uploads them where a server is reachable.
"""

from __future__ import annotations

import sys
from pathlib import Path

import hydra
from omegaconf import DictConfig, OmegaConf

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from dpiil_rl.loggers.replay_to_wandb import replay_markdown, replay_runs  # noqa: E402
from dpiil_rl.utils.cli import comma_list_override, report_user_errors, run_roots  # noqa: E402


@hydra.main(config_path="../configs", config_name="dashboard", version_base="1.3")
@report_user_errors
def main(cfg: DictConfig) -> str:
    if OmegaConf.is_missing(cfg, "runs"):
        raise ValueError("runs: not given; expected runs=<directory of finished runs> (see configs/dashboard.yaml)")
    text = replay_markdown(replay_runs(run_roots(cfg.runs), str(cfg.project), bool(cfg.force)))
    print(text)
    return text


if __name__ == "__main__":
    sys.argv = comma_list_override(sys.argv)
    main()
