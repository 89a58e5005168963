"""The DPIIL loop (paper Algorithm 1) for every method, built from TorchRL primitives.

Why not ``torchrl.trainers.Trainer``: its unit of work is one optimiser step of one loss module
per collected batch. Here an iteration is a collection round of variable length (until N expert
pairs, finishing the episode in progress), after which two models are refitted to convergence on
the whole aggregate, χ is recalibrated and the robot is evaluated alone; resuming must restore a
memmap buffer and χ mid-run. This loop keeps TorchRL's pieces (EnvBase, a BaseCollector,
TensorDictReplayBuffer, TensorDict modules, ``TrainerHookBase`` hooks) and is ~150 lines.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import torch
from tensordict.nn import TensorDictModuleBase, TensorDictSequential
from torchrl.data import TensorDictReplayBuffer
from tqdm.auto import tqdm

from dpiil_rl.collectors.expert_switch import ExpertSwitch
from dpiil_rl.collectors.intervention import Episode, InterventionCollector, NonFiniteValue
from dpiil_rl.collectors.stop_rules import EpisodeBudget, ExpertPairQuota, RoundStats
from dpiil_rl.experts.base import SessionEnded
from dpiil_rl.hooks.base import LoopHook
from dpiil_rl.loggers.run_logger import RunLogger
from dpiil_rl.methods.base import Method
from dpiil_rl.modules.ensemble_actor import EnsembleActor
from dpiil_rl.modules.gate import ConstantGate
from dpiil_rl.modules.speed_head import SpeedHead
from dpiil_rl.records.checkpoints import PAUSE, checkpoint_dir, latest_checkpoint, load_buffer, write_checkpoint
from dpiil_rl.records.metrics import LABELLED_PHASES, run_summary
from dpiil_rl.records.run_files import RunFiles
from dpiil_rl.utils.code_version import code_version
from dpiil_rl.utils.machine import machine_facts

STAGES = ("post_iteration", "post_train")


class InteractiveTrainer:
    """Runs iteration 0 (initial demos) and iterations 1..K (interaction), each followed by hooks."""

    def __init__(
        self,
        *,
        run_dir: str | Path,
        collector: InterventionCollector,
        actor: EnsembleActor,
        speed_head: SpeedHead,
        method: Method,
        buffer: TensorDictReplayBuffer,
        experience: TensorDictReplayBuffer | None = None,
        run_files: RunFiles,
        logger: RunLogger,
        iterations: int,
        demo_episodes: int,
        expert_pairs_per_iteration: int,
        max_episodes_per_iteration: int | None,
        generator: torch.Generator,
        progress: bool = True,
        info: dict[str, Any] | None = None,
    ) -> None:
        if int(iterations) < 0:
            raise ValueError(f"protocol.iterations = {iterations}: expected K >= 0")
        if int(demo_episodes) < 1:
            raise ValueError(f"protocol.demo_episodes = {demo_episodes}: expected at least one demonstration")
        self.run_dir = Path(run_dir)
        self.collector = collector
        self.actor = actor
        self.speed_head = speed_head
        self.method = method
        self.gate = method.make_gate(collector.env, collector.expert)
        self.buffer = buffer
        self.experience = experience  # every executed transition, for methods that learn a critic
        self.run_files = run_files
        self.logger = logger
        self.iterations = int(iterations)
        self.demo_episodes = int(demo_episodes)
        self.quota = ExpertPairQuota(expert_pairs_per_iteration, max_episodes_per_iteration)
        self.generator = generator
        self.progress = progress
        self.info = dict(info or {})
        switch = ExpertSwitch(collector.expert)
        self.demo_policy = TensorDictSequential([ConstantGate(True), switch])
        # a gate may change what is executed after the hand-over (LazyDAgger's noise on the expert's action)
        after = getattr(self.gate, "after_switch", None)
        modules = [actor, speed_head, self.gate, switch, *([after] if after is not None else [])]
        self.interactive_policy: TensorDictModuleBase = TensorDictSequential(*modules)
        self.iteration = -1  # last completed iteration
        self.heldout: torch.Tensor | None = None  # frames of D (training_data order) the last policy refit held out
        self.current_metrics: dict[str, Any] = {}
        self._hooks: dict[str, list[tuple[str, LoopHook]]] = {stage: [] for stage in STAGES}
        self._elapsed_before = 0.0
        self._t_start = time.perf_counter()

    # ------------------------------------------------------------------------------- hooks
    def register_op(self, stage: str, hook: LoopHook, name: str) -> None:
        if stage not in self._hooks:
            raise ValueError(f"hook stage {stage!r}: expected one of {STAGES}")
        if any(n == name for n, _ in self._hooks[stage]):
            raise ValueError(f"hook name {name!r} is already registered at stage {stage!r}")
        self._hooks[stage].append((name, hook))

    def _run_hooks(self, stage: str, after: str | None = None) -> None:
        """Run the stage's hooks in order (``after``: only those registered after the hook of that name)."""
        hooks = self._hooks[stage]
        if after is not None:
            names = [n for n, _ in hooks]
            hooks = hooks[names.index(after) + 1 :] if after in names else hooks
        for _, hook in hooks:
            self.current_metrics.update(hook(self) or {})

    def hook(self, stage: str, name: str) -> LoopHook | None:
        """The hook registered as ``name`` at ``stage``, if any."""
        return next((h for n, h in self._hooks[stage] if n == name), None)

    # ------------------------------------------------------------------------------- loop
    def elapsed(self) -> float:
        return self._elapsed_before + time.perf_counter() - self._t_start

    def record_episode(self, episode: Episode) -> None:
        """Append the episode's row to ``episodes.jsonl`` and, when kept, its path to ``paths.jsonl``.

        ``episode`` is renumbered to the row's index in the run, unique across phases and resumes.
        """
        episode.record["episode"] = len(self.run_files.episodes)
        self.run_files.add_episode(episode.record)
        if episode.positions is not None:
            r = episode.record
            row = {
                "episode": r["episode"],
                "phase": r["phase"],
                "iteration": r["iteration"],
                "positions": [[round(float(v), 4) for v in p] for p in episode.positions],
                "expert_mode": [bool(m) for m in episode.expert_mode],  # type: ignore[union-attr]
                "risk": [float(x) for x in episode.risk],  # type: ignore[union-attr]
            }
            if episode.stage is not None:  # staged tasks: the stage index of every step's state
                row["stage"] = [int(x) for x in episode.stage]
            self.run_files.add_path(row)

    def train(self) -> dict[str, Any]:
        """Run the remaining iterations with the expert source connected (window, pad, stream)."""
        expert = self.collector.expert
        if expert is None:
            return self._train()
        with expert:
            return self._train()

    def _train(self) -> dict[str, Any]:
        first = self.iteration + 1
        bar = tqdm(total=self.iterations + 1, initial=first, desc="iterations", unit="it", disable=not self.progress)
        for k in range(first, self.iterations + 1):
            try:
                self.collect_iteration(k)
                self._run_hooks("post_iteration")
            except (SessionEnded, KeyboardInterrupt, NonFiniteValue):
                self.pause(k)
                raise
            bar.set_postfix(self._postfix())
            bar.update(1)
        bar.close()
        return self.finish()

    @property
    def done(self) -> bool:
        """Whether every iteration has run (what is left is :meth:`finish`)."""
        return self.iteration >= self.iterations

    def collect_iteration(self, k: int) -> None:
        """Start iteration ``k`` and run its collection round; its hooks come next (``post_iteration``)."""
        self.iteration = k
        self.current_metrics = {}
        t0 = time.perf_counter()
        self._collect(k)
        self.current_metrics["time/collect_s"] = time.perf_counter() - t0

    def finish(self) -> dict[str, Any]:
        """After the last iteration: the ``post_train`` hooks, then ``summary.json``."""
        self.current_metrics = {}
        self._run_hooks("post_train")
        summary = self.summary()
        self.run_files.write_summary(summary)
        return summary

    def _collect(self, k: int) -> None:
        if k == 0:
            rule, phase, policy, total, unit = (
                EpisodeBudget(self.demo_episodes),
                "demo",
                self.demo_policy,
                self.demo_episodes,
                "episodes",
            )
        elif self.method.interactive:
            rule, phase, policy, total, unit = (
                self.quota,
                "interactive",
                self.interactive_policy,
                self.quota.pairs,
                "expert pairs",
            )
        else:  # non-interactive methods (BC) get the same number of expert pairs as demonstrations
            rule, phase, policy, total, unit = self.quota, "demo", self.demo_policy, self.quota.pairs, "expert pairs"
        if rule is self.quota:  # expected expert pairs per episode: the previous round (demos before k = 1)
            last = [r for r in self.run_files.episodes if r["phase"] in LABELLED_PHASES and r["iteration"] == k - 1]
            self.quota.expected_per_episode = sum(r["expert_steps"] for r in last) / len(last) if last else 0.0
        # a session paused inside this iteration continues it: its finished episodes count
        done = [r for r in self.run_files.episodes if r["phase"] == phase and r["iteration"] == k]
        start = RoundStats(
            episodes_started=len(done),
            episodes_finished=len(done),
            expert_pairs=sum(int(r["expert_steps"]) for r in done),
        )
        bar = tqdm(
            total=total,
            initial=start.episodes_started if unit == "episodes" else start.expert_pairs,
            desc=f"iter {k} {phase}",
            unit=unit,
            leave=False,
            disable=not self.progress,
        )
        with torch.no_grad():
            for episode in self.collector.rollout(rule, phase, k, policy=policy, start=start):
                self.record_episode(episode)
                bar.update(1 if unit == "episodes" else episode.record["expert_steps"])
        bar.close()

    @property
    def redoes_paused_iterations(self) -> bool:
        """Whether a pause inside an iteration redoes it on resume instead of keeping its finished episodes:
        with a replayable expert (a script) or none, so that a paused run's records are those of a run that
        was never stopped."""
        expert = self.collector.expert
        return expert is None or bool(getattr(expert, "replayable", False))

    def pause(self, k: int) -> None:
        """Stop inside iteration ``k`` (window closed, Ctrl-C, SIGTERM) so that the same command continues.

        With a person (:attr:`redoes_paused_iterations` false) the iteration's finished episodes, their expert
        pairs and every counter are saved as ``checkpoints/pause`` and the run continues from them. With a
        scripted expert nothing is saved: the run resumes from the checkpoint of iteration ``k − 1`` and
        redoes iteration ``k`` whole, as after a crash, so it ends exactly as an uninterrupted run (a pause
        checkpoint would start its unfinished episodes again on other start states, and a pause during the
        refit would keep the random draws the refit had already made)."""
        if latest_checkpoint(self.run_dir) == checkpoint_dir(self.run_dir, k):
            return  # stopped after iteration k was saved: nothing to add
        if self.redoes_paused_iterations:
            self.iteration = k - 1
            return
        rows = self.run_files.episodes
        # the hooks' episodes of iteration k (rollouts, tests) come after its collection: they are redone
        evaluated = next(
            (i for i, r in enumerate(rows) if r["phase"] not in LABELLED_PHASES and r["iteration"] == k), len(rows)
        )
        self.run_files.truncate(evaluated, min(len(self.run_files.metrics), k))  # k's test and row are redone
        self.iteration = k - 1
        write_checkpoint(self, Path(self.run_dir) / "checkpoints" / PAUSE)

    def _postfix(self) -> dict[str, str]:
        row = self.run_files.metrics[-1] if self.run_files.metrics else {}
        out = {}
        for key, label in (
            ("autonomous_success", "auto"),
            ("interactive_success", "inter"),
            ("expert_actions", "pairs"),
        ):
            if row.get(key) is not None:
                out[label] = f"{row[key]:.2f}" if isinstance(row[key], float) else str(row[key])
        return out

    def summary(self) -> dict[str, Any]:
        summary = {**self.info, **run_summary(self.run_files.episodes)}
        summary["wall_time_s"] = round(self.elapsed(), 3)
        summary["machine"] = machine_facts()  # what the records' bits depend on beyond the config
        summary["code"] = code_version()  # the package version and, from a git checkout, its commit
        if self.collector.stage_names:  # a multi-stage task: its stages in order (episodes record the furthest)
            summary["stages"] = list(self.collector.stage_names)
        return summary

    # ------------------------------------------------------------------------------- resume
    def state_dict(self) -> dict[str, Any]:
        return {
            "iteration": self.iteration,
            "actor": self.actor.state_dict(),
            "speed_head": self.speed_head.state_dict(),
            "gate": self.gate.state_dict(),
            "collector": self.collector.state_dict(),
            "generator": self.generator.get_state(),
            "torch_rng": torch.get_rng_state(),
            "episodes_rows": len(self.run_files.episodes),
            "metrics_rows": len(self.run_files.metrics),
            "elapsed_s": self.elapsed(),
            "hooks": {
                f"{stage}/{name}": hook.state_dict() for stage, hooks in self._hooks.items() for name, hook in hooks
            },
            "info": self.info,
        }

    def buffers(self) -> dict[str, TensorDictReplayBuffer]:
        """The run's buffers by checkpoint sub-directory name (saved and restored with the state)."""
        out = {"buffer": self.buffer}
        if self.experience is not None:
            out["experience"] = self.experience
        return out

    def load_state_dict(self, state: dict[str, Any], checkpoint: str | Path) -> None:
        self.iteration = int(state["iteration"])
        self.actor.load_state_dict(state["actor"])
        self.speed_head.load_state_dict(state["speed_head"])
        self.gate.load_state_dict(state["gate"])
        self.collector.load_state_dict(state["collector"])
        self.generator.set_state(state["generator"])
        torch.set_rng_state(state["torch_rng"])
        for name, buffer in self.buffers().items():
            load_buffer(buffer, checkpoint, name)
        self.run_files.truncate(int(state["episodes_rows"]), int(state["metrics_rows"]))
        self._elapsed_before = float(state["elapsed_s"])
        self._t_start = time.perf_counter()
        for stage, hooks in self._hooks.items():
            for name, hook in hooks:
                hook.load_state_dict(state["hooks"].get(f"{stage}/{name}", {}))
