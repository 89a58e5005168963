"""Several runs of one study in one process, iteration by iteration: the seeds of a method batched.

Each run keeps its own env, expert, buffers, generators, records and checkpoints; only the refits are
shared — every run's actor (and speed head) is fitted in one minibatch loop with the others'
(:func:`~dpiil_rl.hooks.refit.refit_runs`), which ends exactly where each refit would alone. A run's
records are therefore the same whether it ran alone, in a multirun, or batched with other seeds (tested),
and a batch costs one start-up and about one refit per iteration instead of one per run.

Runs resumed from different iterations are advanced in groups: the runs that are furthest behind first.
A stop signal or a closed session pauses every run in the middle of its iteration (each writes its
``pause`` checkpoint, as a run alone would) and is raised again.
"""

from __future__ import annotations

import contextlib
from typing import Any, Callable, Sequence

from dpiil_rl.collectors.intervention import NonFiniteValue
from dpiil_rl.experts.base import SessionEnded
from dpiil_rl.hooks.refit import RefitHook, refit_runs
from dpiil_rl.training.interactive_trainer import InteractiveTrainer

REFIT = "refit"  # the name the refit hook is registered under (training.factory)


def _refit_hook(trainer: InteractiveTrainer) -> RefitHook | None:
    hook = trainer.hook("post_iteration", REFIT)
    return hook if isinstance(hook, RefitHook) else None


def train_lockstep(
    trainers: Sequence[InteractiveTrainer],
    on_finished: Callable[[InteractiveTrainer, dict[str, Any]], None] | None = None,
) -> list[dict[str, Any]]:
    """Train every run to its end; returns their summaries in order. ``on_finished`` is called as each ends."""
    summaries: dict[int, dict[str, Any]] = {}
    with contextlib.ExitStack() as stack:
        for trainer in trainers:
            if trainer.collector.expert is not None:
                stack.enter_context(trainer.collector.expert)
        pending = list(trainers)
        while pending:
            for trainer in [t for t in pending if t.done]:  # resumed after its last iteration: only the end is left
                summaries[id(trainer)] = trainer.finish()
                pending.remove(trainer)
                if on_finished is not None:
                    on_finished(trainer, summaries[id(trainer)])
            if not pending:
                break
            k = min(t.iteration + 1 for t in pending)
            group = [t for t in pending if t.iteration + 1 == k]
            started: list[InteractiveTrainer] = []
            try:
                for trainer in group:
                    started.append(trainer)
                    trainer.collect_iteration(k)
                joint = [(t, h) for t in group if (h := _refit_hook(t)) is not None]
                for (trainer, _), metrics in zip(joint, refit_runs(joint)):
                    trainer.current_metrics.update(metrics)
                for trainer in group:
                    trainer._run_hooks("post_iteration", after=REFIT if _refit_hook(trainer) is not None else None)
            except (SessionEnded, KeyboardInterrupt, NonFiniteValue):
                for trainer in started:
                    trainer.pause(k)  # a run whose iteration k was already saved returns at once
                raise
    return [summaries[id(t)] for t in trainers]
