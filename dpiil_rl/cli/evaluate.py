"""Evaluate a saved run's policy: ``dpiil-evaluate run_dir=runs/... episodes=100``,
or every finished run of a study on the same start states: ``dpiil-evaluate runs=runs/paper/ring``.

Recipe: load the run's config and latest (or chosen) checkpoint → apply env overrides → run the
robot alone on a batched env → print and write ``<run_dir>/evaluations/<name>.json``. With ``runs``:
the same for each finished run below it, then a study table ``<out>/<name>.md`` (success per method over
seeds and, on multi-stage tasks, how far the failed episodes got).
"""

from __future__ import annotations

import json
from typing import Any, cast

import hydra
from omegaconf import DictConfig, OmegaConf

from dpiil_rl.study.common_starts import evaluate_study
from dpiil_rl.training.evaluation import evaluate_run
from dpiil_rl.utils.cli import report_user_errors


@hydra.main(config_path="../configs", config_name="evaluate", version_base="1.3")
@report_user_errors
def run(cfg: DictConfig) -> dict:
    if (cfg.run_dir is None) == (cfg.runs is None):
        raise ValueError(
            f"run_dir = {cfg.run_dir!r}, runs = {cfg.runs!r}: expected exactly one of them "
            "(run_dir=<one run> or runs=<a directory of runs>)"
        )
    if cfg.runs is not None:
        if cfg.iteration is not None or cfg.env:
            raise ValueError(
                f"iteration = {cfg.iteration!r}, env = {OmegaConf.to_container(cfg.env)}: with runs=... "
                "every run's final policy is evaluated on its own task (expected neither)"
            )
        result = evaluate_study(
            cfg.runs,
            episodes=cfg.episodes,
            num_envs=cfg.num_envs,
            max_envs=cfg.max_envs,
            seed=cfg.seed,
            name=cfg.name,
            out_dir=cfg.out,
            fresh=cfg.fresh,
        )
        print(result["markdown"])
        if result["reused"]:
            print(
                f"{result['reused']} of {result['runs']} runs already had this evaluation and were not run again "
                "(fresh=true re-runs them)"
            )
        print(f"wrote {result['out_dir']}/{result['name']}.md and .json")
        return result
    result = evaluate_run(
        cfg.run_dir,
        episodes=cfg.episodes,
        num_envs=cfg.num_envs,
        iteration=cfg.iteration,
        seed=cfg.seed,
        env_overrides=cast("dict[str, Any]", OmegaConf.to_container(cfg.env, resolve=True)),  # a mapping's container
        name=cfg.name,  # type: ignore[arg-type]
        max_envs=cfg.max_envs,
    )
    print(json.dumps(result, indent=2))
    return result


def main() -> None:
    """The ``dpiil-evaluate`` command."""
    run()


if __name__ == "__main__":
    main()
