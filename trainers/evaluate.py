"""Evaluate a saved run's policy: ``python trainers/evaluate.py run_dir=runs/... episodes=100``.

Recipe: load the run's config and latest (or chosen) checkpoint → apply env overrides → run the
robot alone on a batched env → print and write ``<run_dir>/evaluations/<name>.json``.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import hydra
from omegaconf import DictConfig, OmegaConf

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from dpiil_rl.training.evaluation import evaluate_run  # noqa: E402
from dpiil_rl.utils.cli import report_user_errors  # noqa: E402


@hydra.main(config_path="../configs", config_name="evaluate", version_base="1.3")
@report_user_errors
def main(cfg: DictConfig) -> dict:
    result = evaluate_run(
        cfg.run_dir, episodes=cfg.episodes, num_envs=cfg.num_envs, iteration=cfg.iteration, seed=cfg.seed,
        env_overrides=OmegaConf.to_container(cfg.env, resolve=True), name=cfg.name,  # type: ignore[arg-type]
    )
    print(json.dumps(result, indent=2))
    return result


if __name__ == "__main__":
    main()
