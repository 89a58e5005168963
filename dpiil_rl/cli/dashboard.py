"""Offline wandb runs from finished runs' records: ``dpiil-dashboard runs=runs/paper/ring``
(or ``make dashboard RUNS=...``).

For runs that logged to CSV or nothing, or whose records were copied without their ``wandb/`` folder
(:mod:`dpiil_rl.study.replay_to_wandb`). ``make sync RUNS=...`` uploads them where a server is reachable.
"""

from __future__ import annotations

import hydra
from omegaconf import DictConfig, OmegaConf

from dpiil_rl.study.replay_to_wandb import replay_markdown, replay_runs
from dpiil_rl.utils.cli import report_user_errors, run_roots


@hydra.main(config_path="../configs", config_name="dashboard", version_base="1.3")
@report_user_errors
def run(cfg: DictConfig) -> str:
    if OmegaConf.is_missing(cfg, "runs"):
        raise ValueError("runs: not given; expected runs=<directory of finished runs> (see configs/dashboard.yaml)")
    text = replay_markdown(replay_runs(run_roots(cfg.runs), str(cfg.project), bool(cfg.force)))
    print(text)
    return text


def main() -> None:
    """The ``dpiil-dashboard`` command."""
    run()


if __name__ == "__main__":
    main()
