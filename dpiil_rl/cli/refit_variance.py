"""Refit a run's actor many times on the same dataset and test every refit and member alone:
``dpiil-refit-variance run_dir=runs/... iteration=5 'overrides=[modules.actor.fit.schedule=constant]'``."""

from __future__ import annotations

import json

import hydra
from omegaconf import DictConfig

from dpiil_rl.training.refit_variance import refit_variance
from dpiil_rl.utils.cli import report_user_errors


@hydra.main(config_path="../configs", config_name="refit_variance", version_base="1.3")
@report_user_errors
def run(cfg: DictConfig) -> None:
    result = refit_variance(cfg.run_dir, int(cfg.iteration), int(cfg.fits), int(cfg.episodes), list(cfg.overrides))
    for i, r in enumerate(result["refits"]):
        print(
            f"refit {i}: mean policy {r['mean_policy']:.2f}, "
            f"members {' '.join(f'{m:.2f}' for m in r['members'])} ({r['fit_s']} s)"
        )
    print(
        f"{result['run_dir']} k={result['iteration']} |D|={result['dataset_size']} "
        f"{' '.join(result['overrides']) or '(run settings)'}: "
        f"mean policy {result['mean_policy_success']:.2f} "
        f"({result['mean_policy_collapsed']} of {len(result['refits'])} below 10%), "
        f"members {result['member_success']:.2f} ({result['members_failing_all']} of {result['members']} below 10%)"
    )
    print(json.dumps({k: v for k, v in result.items() if k != "refits"}))


def main() -> None:
    """The ``dpiil-refit-variance`` command."""
    run()


if __name__ == "__main__":
    main()
