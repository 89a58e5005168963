"""A Hydra launcher that runs the seeds of each setting batched in one process (``hydra/launcher=lockstep``).

``train.py -m method=a,b seed=0,1,2 hydra/launcher=lockstep`` groups the jobs that differ only in their
seed, and trains each group in one worker process with :func:`~dpiil_rl.training.run.run_batched` (their
refits share one loop; every run's records are those it would write alone). ``n_jobs`` groups run at
once (worker processes, as the joblib launcher's ``n_jobs``), ``max_batch`` seeds at most per group.
Run directories, ``.hydra/`` files, finished-run skipping and resuming are those of a single run.
"""

from __future__ import annotations

import copy
import os
import sys
from collections import defaultdict
from pathlib import Path
from typing import Sequence, cast

from hydra.core.hydra_config import HydraConfig
from hydra.core.utils import JobReturn, JobStatus, _save_config, configure_log, filter_overrides, setup_globals
from hydra.plugins.launcher import Launcher
from hydra.types import HydraContext, TaskFunction
from omegaconf import DictConfig, open_dict, read_write

from dpiil_rl.utils.sweep_progress import ENV_VAR


def _prepare(config: DictConfig) -> tuple[DictConfig, Path]:
    """What Hydra's ``run_job`` does before calling the task: the job's output directory and its ``.hydra/``
    files; returns the task's config (without ``hydra``) and the run directory."""
    HydraConfig.instance().set_config(config)
    output = Path(str(config.hydra.sweep.dir)) / str(config.hydra.sweep.subdir)
    with read_write(config.hydra.runtime), open_dict(config.hydra.runtime):
        config.hydra.runtime.output_dir = str(output.absolute())
    HydraConfig.instance().set_config(config)
    task = copy.deepcopy(config)
    with read_write(task), open_dict(task):
        del task["hydra"]
    output.mkdir(parents=True, exist_ok=True)
    if config.hydra.output_subdir is not None:
        folder = output / str(config.hydra.output_subdir)
        _save_config(task, "config.yaml", folder)
        # the config set above (a DictConfig; HydraConfig types it as its dataclass)
        _save_config(cast(DictConfig, copy.deepcopy(HydraConfig.instance().cfg)), "hydra.yaml", folder)
        _save_config(config.hydra.overrides.task, "overrides.yaml", folder)
    return task, output


def _progress(run_dir: Path) -> None:
    """One line in the sweep's progress file (:mod:`dpiil_rl.utils.sweep_progress`) per finished run."""
    path = os.environ.get(ENV_VAR)
    if path:
        with open(path, "a") as fh:
            fh.write(f"COMPLETED {'/'.join(run_dir.parts[-3:])}\n")


def run_group(runs: Sequence[tuple[DictConfig, Path]]) -> list[str]:
    """Worker: train one group of runs batched; a stop signal pauses them all and ends the worker."""
    from dpiil_rl.training.run import run_batched
    from dpiil_rl.utils.stop_signals import StopRequested, release_semaphores, stop_signals_pause

    try:
        with stop_signals_pause():
            run_batched(runs, on_finished=_progress)
    except StopRequested as stop:
        print(
            f"[dpiil_rl] batch paused ({stop}): every finished iteration is saved (a person's finished episodes "
            "too); run the same command to continue",
            flush=True,
        )
        sys.stdout.flush()
        release_semaphores()
        os._exit(stop.exit_code)
    return [str(d) for _, d in runs]


def split_batches(groups: Sequence[Sequence[int]], max_batch: int, workers: int) -> list[list[int]]:
    """Chunks of at most ``max_batch`` jobs of one group; while there are fewer chunks than ``workers``, the
    largest is halved (10 seeds on 2 workers: two batches of 5), so every worker has a batch."""
    batches = [list(ids[j : j + max_batch]) for ids in groups for j in range(0, len(ids), max_batch)]
    while 0 < len(batches) < workers and max(len(b) for b in batches) > 1:
        big = max(batches, key=len)
        batches.remove(big)
        half = (len(big) + 1) // 2
        batches += [big[:half], big[half:]]
    return batches


class LockstepLauncher(Launcher):
    def __init__(self, n_jobs: int = 2, max_batch: int = 5) -> None:
        super().__init__()
        if int(n_jobs) < 1 or int(max_batch) < 1:
            raise ValueError(f"hydra.launcher: n_jobs = {n_jobs}, max_batch = {max_batch}: expected positive numbers")
        self.n_jobs, self.max_batch = int(n_jobs), int(max_batch)
        self.config: DictConfig | None = None
        self.hydra_context: HydraContext | None = None

    def setup(self, *, hydra_context: HydraContext, task_function: TaskFunction, config: DictConfig) -> None:
        del task_function  # the runs are trained by run_batched, not one task call each
        self.config, self.hydra_context = config, hydra_context

    def launch(self, job_overrides: Sequence[Sequence[str]], initial_job_idx: int) -> Sequence[JobReturn]:
        from joblib import Parallel, delayed

        setup_globals()
        assert self.config is not None and self.hydra_context is not None
        configure_log(self.config.hydra.hydra_logging, self.config.hydra.verbose)
        Path(str(self.config.hydra.sweep.dir)).mkdir(parents=True, exist_ok=True)
        groups: dict[tuple[str, ...], list[int]] = defaultdict(list)
        prepared: list[tuple[list[str], DictConfig, DictConfig, Path]] = []
        for i, overrides in enumerate(job_overrides):
            config = self.hydra_context.config_loader.load_sweep_config(self.config, list(overrides))
            with open_dict(config):
                config.hydra.job.id = config.hydra.job.num = initial_job_idx + i
            task, run_dir = _prepare(config)
            prepared.append((list(overrides), config, task, run_dir))
            key = tuple(o for o in filter_overrides(list(overrides)) if not o.startswith("seed="))
            groups[key].append(i)
        batches = split_batches(list(groups.values()), self.max_batch, self.n_jobs)
        Parallel(n_jobs=min(self.n_jobs, len(batches)), backend="loky")(
            delayed(run_group)([(prepared[i][2], prepared[i][3]) for i in batch]) for batch in batches
        )
        returns = []
        for overrides, config, task, run_dir in prepared:
            ret = JobReturn(overrides=overrides, cfg=task, hydra_cfg=config, working_dir=os.getcwd(), task_name="train")
            ret.status = JobStatus.COMPLETED if (run_dir / "summary.json").exists() else JobStatus.FAILED
            ret._return_value = (
                str(run_dir) if ret.status == JobStatus.COMPLETED else RuntimeError(f"{run_dir} did not finish")
            )
            returns.append(ret)
        return returns
