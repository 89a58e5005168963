"""Train one run: ``dpiil-train env=aperture method=dpiil_ucb seed=0`` (or ``make train``).

Recipe: resolve the run directory → skip it if finished, resume it if it has a checkpoint →
build env, expert, modules, collector, buffer, hooks → run Algorithm 1 → test the final policy on the
protocol's common start states (``protocol.final_eval_episodes``) → print the summary.
A stop signal (SIGTERM from a batch system, Ctrl-C) pauses the run: the same command continues it.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig

from dpiil_rl.experts.base import SessionEnded
from dpiil_rl.records.record_subdir import register as register_record_subdir
from dpiil_rl.records.summary_table import print_summary
from dpiil_rl.training.final_evaluation import final_evaluation
from dpiil_rl.training.run import prepare_run
from dpiil_rl.utils.cli import check_run_root, report_user_errors
from dpiil_rl.utils.stop_signals import StopRequested, release_semaphores, stop_signals_pause

register_record_subdir()  # hydra.output_subdir: a finished run's .hydra/ is not rewritten


@hydra.main(config_path="../configs", config_name="config", version_base="1.3")
@report_user_errors
def run(cfg: DictConfig) -> dict:
    run_dir = Path(HydraConfig.get().runtime.output_dir)
    trainer = prepare_run(cfg, run_dir)
    if trainer is None:  # finished already (its final evaluation too, unless it was stopped during it)
        final_evaluation(cfg, run_dir)
        return print_summary(run_dir)
    stopped: StopRequested | None = None
    try:
        with stop_signals_pause():  # SIGTERM / SIGINT / SIGHUP: save the pause checkpoint, then stop
            trainer.train()
    except (SessionEnded, KeyboardInterrupt) as ended:
        why = str(ended) or "interrupted"
        kept = (
            "the iteration in progress is redone from its start when it continues (a scripted expert: the run "
            "ends as if never stopped)"
            if trainer.redoes_paused_iterations
            else "every finished episode is saved"
        )
        print(
            f"[dpiil_rl] session paused ({why}): {kept} ({run_dir}); run the same command to continue where it stopped",
            flush=True,
        )
        stopped = ended if isinstance(ended, StopRequested) else None
        return {}
    finally:
        trainer.logger.close()
        if stopped is not None:
            # End the process now: in a sweep (make paper) a joblib worker would otherwise take the next
            # queued run, and an exception would only be handed back to a parent that is gone.
            sys.stdout.flush()
            sys.stderr.flush()
            release_semaphores()
            os._exit(stopped.exit_code)
    final_evaluation(cfg, run_dir)
    return print_summary(run_dir)


def main() -> None:
    """The ``dpiil-train`` command."""
    check_run_root(sys.argv[1:])
    run()


if __name__ == "__main__":
    main()
