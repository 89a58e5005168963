"""Refit the ensemble actor and the speed head on the aggregate dataset D (Algorithm 1, line 6).

:func:`refit_runs` refits several runs at once (seeds batched in one process): their fits share one
minibatch loop (:func:`~dpiil_rl.modules.joint_fit.fit_jointly`) and end exactly where each would alone,
because every random draw comes from the run's own generator in the same order as a refit alone.
"""

from __future__ import annotations

import time
from collections import defaultdict
from typing import TYPE_CHECKING, Any, Sequence, cast

import torch

from dpiil_rl.data.buffer import training_data
from dpiil_rl.data.splits import heldout_episodes
from dpiil_rl.hooks.base import LoopHook
from dpiil_rl.modules.ensemble_actor import action_loss
from dpiil_rl.modules.fitting import FitSettings
from dpiil_rl.modules.joint_fit import FitJob, MemberLoss, draw_batches, fit_jointly
from dpiil_rl.modules.speed_head import speed_loss

if TYPE_CHECKING:
    from tensordict import TensorDictBase

    from dpiil_rl.training.interactive_trainer import InteractiveTrainer


class RefitHook(LoopHook):
    def __init__(self, actor_fit: FitSettings, speed_fit: FitSettings) -> None:
        self.actor_fit = actor_fit
        self.speed_fit = speed_fit

    def __call__(self, trainer: "InteractiveTrainer") -> dict[str, Any]:
        return refit_runs([(trainer, self)])[0]


def _fit_groups(jobs: Sequence[tuple[FitJob, MemberLoss, torch.Tensor]]) -> None:
    """Fit jobs together where their network shapes and batch size agree (the runs of one config, and within a
    run its actor and speed head when their layers have the same shapes), each with its own loss and its
    minibatches drawn beforehand."""
    groups: dict[tuple, list[tuple[FitJob, MemberLoss, torch.Tensor]]] = defaultdict(list)
    for job, loss, batches in jobs:
        groups[(job.batch_size(), tuple(tuple(w.shape[1:]) for w in job.weights))].append((job, loss, batches))
    for group in groups.values():
        rank = {id(loss): r for r, loss in enumerate(dict.fromkeys(loss for _, loss, _ in group))}
        group = sorted(group, key=lambda g: rank[id(g[1])])  # the jobs of one loss side by side (stable)
        fit_jointly([g[0] for g in group], [g[1] for g in group], [g[2] for g in group])


def refit_runs(runs: Sequence[tuple["InteractiveTrainer", RefitHook]]) -> list[dict[str, Any]]:
    """Refit every run's actor and every run's speed head (where its method reads it, or after the demos) in
    one loop; returns each run's metrics. A run's random draws are those of a refit alone, in its order: the
    actor's initialisation and minibatches, then the speed head's (drawn before the loop; the held-out split is
    a hash, no draw)."""
    t0 = time.perf_counter()
    datas, jobs = [], []
    actor_jobs: list[FitJob] = []
    speed_jobs: list[FitJob | None] = []
    speed_losses: dict[float, MemberLoss] = {}
    for trainer, hook in runs:
        data = training_data(trainer.buffer)
        # a method whose gate has its own model holds some episodes out of the policy's fit for it
        heldout = heldout_episodes(data["episode"], trainer.method.heldout_fraction, int(trainer.info.get("seed", 0)))
        trainer.heldout = heldout
        policy_data = cast("TensorDictBase", data[~heldout])  # a mask picks frames: a tensordict
        job = trainer.actor.fit_job(
            policy_data["observation"], policy_data["expert_action"], hook.actor_fit, trainer.generator
        )
        jobs.append((job, action_loss, draw_batches(job)))
        datas.append((data, heldout))
        actor_jobs.append(job)
        # the speed head is refitted for methods whose gate reads it; the others fit it once, on the
        # initial demos (every run's precision map after k = 0), and save the refits
        if not (trainer.method.uses_speed_head or trainer.iteration == 0):
            speed_jobs.append(None)
            continue
        drove = data.get("expert_drove", None)  # the expert's own speeds only (not labels of robot-driven states)
        speeds = data if drove is None else cast("TensorDictBase", data[drove.reshape(-1).bool()])
        speed = trainer.speed_head.fit_job(speeds["observation"], speeds["speed"], hook.speed_fit, trainer.generator)
        sigma = trainer.speed_head.min_sigma
        jobs.append((speed, speed_losses.setdefault(sigma, speed_loss(sigma)), draw_batches(speed)))
        speed_jobs.append(speed)
    _fit_groups(jobs)
    elapsed = (time.perf_counter() - t0) / len(runs)  # shared: each run is charged its share
    out = []
    for (trainer, _), (data, heldout), actor_job, speed in zip(runs, datas, actor_jobs, speed_jobs):
        tail = max(1, len(actor_job.losses) // 20)
        metrics: dict[str, Any] = {
            "dataset_size": int(data.shape[0]),
            "train/actor_mse": sum(actor_job.losses[-tail:]) / tail,
        }
        if trainer.method.heldout_fraction:
            metrics["train/heldout_frames"] = int(heldout.sum())
        if speed is not None:
            metrics["train/speed_nll"] = sum(speed.losses[-tail:]) / tail
        metrics["time/refit_s"] = elapsed
        out.append(metrics)
    return out
