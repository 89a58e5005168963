"""The intervention collector: one loop for every method, expert source and phase.

Every step it runs the policy (actor → speed head → gate → expert switch), steps the batched env
with partial resets, and keeps, per environment, the episode's counters. Expert-labelled frames
(observation, the expert's action, the speed ``v = ‖pos_{t+1} − pos_t‖²``) go to the replay
buffer; everything the robot did alone is only counted, unless an ``experience_buffer`` is given:
it receives every executed transition (s, a, s', success, done) of the round, for methods that
learn a critic from the robot's own experience. It never knows which expert it drives.

Frames reach a buffer when their episode ends, just before the episode is handed out, so a round
stopped part-way (a signal, a closed window, a crash) leaves in the buffers exactly the frames of the
episodes it recorded; the unfinished episodes are run again on resume, and nothing is counted twice.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Iterator, cast

import torch
from tensordict import TensorDict, TensorDictBase
from tensordict.nn import TensorDictModuleBase
from torchrl.collectors import BaseCollector
from torchrl.data import ReplayBuffer
from torchrl.envs import EnvBase

from dpiil_rl.collectors.stop_rules import EpisodeBudget, RoundStats, StopRule
from dpiil_rl.experts.base import ExpertSource


@dataclass
class Episode:
    """One finished episode: its record (a row of ``episodes.jsonl``) and, if kept, its path."""

    record: dict[str, Any]
    positions: torch.Tensor | None = None  # [T + 1, pos_dim]
    expert_mode: torch.Tensor | None = None  # [T] bool
    risk: torch.Tensor | None = None  # [T]
    stage: torch.Tensor | None = None  # [T] int64: the stage of the state each step was decided in (staged tasks)
    env_index: int = -1  # the env of the batch that ran it (not recorded: the order of episodes that end together)


@dataclass
class _Round:
    rule: StopRule
    phase: str
    iteration: int
    stats: RoundStats = field(default_factory=RoundStats)


class NonFiniteValue(ValueError):
    """An env or an expert source produced NaN or infinity: the run stops (pausing, nothing recorded is lost)."""


def _check_finite(td: TensorDictBase, key: str, active: torch.Tensor, what: str, phase: str, iteration: int) -> None:
    value = td.get(key, None)
    if value is None or value.dtype == torch.bool:
        return
    bad = ~torch.isfinite(value.reshape(active.shape[0], -1)).all(-1) & active
    if bool(bad.any()):
        i = int(bad.nonzero()[0])
        raise NonFiniteValue(
            f"{what} of robot {i} ({phase}, iteration {iteration}) is "
            f"{value.reshape(active.shape[0], -1)[i].tolist()}: "
            "expected finite numbers (a device glitch, a broken expert source or a diverged simulation); "
            "the run paused, its finished episodes are saved"
        )


def _flag(td: TensorDictBase, key: Any, n: int) -> torch.Tensor:
    value = td.get(key, None)
    if value is None:
        return torch.zeros(n, dtype=torch.bool)
    return value.reshape(n).bool()


class InterventionCollector(BaseCollector):
    """Collect episodes from a batched env ``[N]`` with expert hand-over.

    Use :meth:`rollout` for one round (``for episode in collector.rollout(rule, phase, k)``) or
    set a round with :meth:`set_round` and iterate the collector (TorchRL style).
    """

    def __init__(
        self,
        env: EnvBase,
        policy: TensorDictModuleBase,
        *,
        expert: ExpertSource | None = None,
        replay_buffer: ReplayBuffer | None = None,
        experience_buffer: ReplayBuffer | None = None,
        position_key: str | None = None,
        observation_key: str = "observation",
        keep_paths: bool = False,
    ) -> None:
        super().__init__()
        if len(env.batch_size) != 1:
            raise ValueError(f"env.batch_size = {tuple(env.batch_size)}: expected a 1-D batch [N]")
        self.env = env
        self.policy = policy
        self.expert = expert
        self.replay_buffer = replay_buffer
        self.experience_buffer = experience_buffer
        self.observation_key = observation_key
        self.position_key = position_key or getattr(env, "position_key", observation_key)
        self.keep_paths = keep_paths
        # multi-stage tasks (the env writes ``stage``): each record names the furthest stage the episode reached
        self.stage_names: tuple[str, ...] = tuple(getattr(env, "stage_names", ()) or ())
        self.episode_counter = 0
        self._round: _Round | None = None

    # -------------------------------------------------------------------------- TorchRL API
    def set_round(self, rule: StopRule, phase: str, iteration: int) -> None:
        self._round = _Round(rule, phase, iteration)

    def iterator(self) -> Iterator[Episode]:
        if self._round is None:
            raise RuntimeError("InterventionCollector: call set_round(rule, phase, iteration) before iterating")
        r = self._round
        yield from self.rollout(r.rule, r.phase, r.iteration)

    def set_seed(self, seed: int, static_seed: bool = False) -> int | None:
        return self.env.set_seed(seed, static_seed=static_seed)

    def state_dict(self) -> dict[str, Any]:
        state: dict[str, Any] = {"episode_counter": self.episode_counter}
        rng = getattr(self.env, "rng", None)
        if isinstance(rng, torch.Generator):
            state["env_rng"] = rng.get_state()
        if self.expert is not None:
            state["expert"] = self.expert.state_dict()
        return state

    def load_state_dict(self, state_dict: dict[str, Any], **kwargs: Any) -> None:
        self.episode_counter = int(state_dict["episode_counter"])
        rng = getattr(self.env, "rng", None)
        if "env_rng" in state_dict and isinstance(rng, torch.Generator):
            rng.set_state(state_dict["env_rng"])
        if self.expert is not None and "expert" in state_dict:
            self.expert.load_state_dict(state_dict["expert"])

    def shutdown(self, timeout: float | None = None, close_env: bool = True) -> None:
        if close_env and not self.env.is_closed:
            self.env.close()

    # -------------------------------------------------------------------------- one round
    def rollout(
        self,
        rule: StopRule,
        phase: str,
        iteration: int,
        policy: TensorDictModuleBase | None = None,
        start: RoundStats | None = None,
    ) -> Iterator[Episode]:
        """Run one round: start episodes while ``rule`` allows, finish those in progress, yield each.

        ``policy`` overrides the collector's policy for this round (e.g. expert-only demonstrations);
        ``start`` continues a round that was paused (its finished episodes and pairs count toward ``rule``).
        """
        env, n = self.env, self.env.batch_size[0]
        policy = self.policy if policy is None else policy
        stats = RoundStats(**vars(start)) if start is not None else RoundStats()
        self._round = _Round(rule, phase, iteration, stats)
        active = torch.zeros(n, dtype=torch.bool)
        for i in range(n):
            if rule.may_start(stats):
                active[i] = True
                stats.episodes_started += 1
        if not bool(active.any()):
            return
        module: Any  # per-round hooks are duck-typed: reset_history, start_round
        for module in policy.modules():
            if module is not policy and hasattr(module, "reset_history"):
                module.reset_history()
            if module is not policy and hasattr(module, "start_round"):  # e.g. DAgger's β of this iteration
                module.start_round(int(iteration), phase)
        if self.expert is not None:
            self.expert.reset(torch.ones(n, dtype=torch.bool))
        td = env.reset()
        length = torch.zeros(n, dtype=torch.long)
        expert_steps = torch.zeros(n, dtype=torch.long)  # expert-labelled steps: the pairs entering D
        control_steps = torch.zeros(n, dtype=torch.long)  # steps the expert drove
        queries = torch.zeros(n, dtype=torch.long)  # steps the expert had to act or judge (monitoring included)
        interventions = torch.zeros(n, dtype=torch.long)
        contact_steps = torch.zeros(
            n, dtype=torch.long
        )  # steps with a collision (tasks where contact does not end the episode)
        stage_reached = torch.zeros(n, dtype=torch.long)  # furthest stage of the episode (tasks with stage_names)
        paths: list[tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor | None]] = []
        path_start = torch.zeros(n, dtype=torch.long)
        start_pos = td.get(self.position_key).reshape(n, -1).clone()
        pending, pending_experience = PendingFrames(), PendingFrames()

        while bool(active.any()):
            td = policy(td)
            _check_finite(td, "action", active, "the executed action (the policy's or the expert's)", phase, iteration)
            td, td_next = env.step_and_maybe_reset(td)
            _check_finite(td.get("next"), self.observation_key, active, "the env's next observation", phase, iteration)
            mode = td.get("expert_mode").reshape(n) & active
            # where the expert's action is a demonstration (a person who holds the robot still gives none)
            label = td.get("expert_labelled", None)
            label = mode if label is None else label.reshape(n) & active
            inter = td.get("intervention", None)
            inter = torch.zeros(n, dtype=torch.bool) if inter is None else inter.reshape(n) & active
            queried = td.get("expert_queried", None)
            queried = mode | label if queried is None else queried.reshape(n) & active
            length += active.long()
            expert_steps += label.long()
            control_steps += mode.long()
            queries += queried.long()
            interventions += inter.long()
            contact_steps += (_flag(td.get("next"), "collision", n) & active).long()
            if self.stage_names:
                stage = td.get(("next", "stage")).reshape(n).long()
                stage_reached = torch.where(active, torch.maximum(stage_reached, stage), stage_reached)
            n_expert = int(label.sum())
            stats.expert_pairs += n_expert
            stats.steps += int(active.sum())
            if n_expert and self.replay_buffer is not None:
                pending.add(self._expert_frames(td, label, iteration), label.nonzero().reshape(-1))
            if self.experience_buffer is not None:
                pending_experience.add(self._transitions(td, active), active.nonzero().reshape(-1))
            if self.keep_paths:
                risk = td.get("risk", None)
                risk = torch.full((n,), float("nan")) if risk is None else risk.reshape(n).float()
                # the stage of the state the step was decided in (its expert_mode's state), not the next one
                now = td.get("stage").reshape(n).long().clone() if self.stage_names else None
                paths.append((td.get(("next", self.position_key)).reshape(n, -1).clone(), mode.clone(), risk, now))
            done = td.get(("next", "done")).reshape(n) & active
            if bool(done.any()):
                nxt = td.get("next")
                success = _flag(nxt, "success", n).tolist()
                contacts = contact_steps.tolist()
                out = _flag(nxt, "out_of_bounds", n).tolist()
                truncated = _flag(nxt, "truncated", n).tolist()
                lengths, experts, inters = length.tolist(), expert_steps.tolist(), interventions.tolist()
                controls, asked = control_steps.tolist(), queries.tolist()
                starts = start_pos.tolist()
                for i in done.nonzero().reshape(-1).tolist():
                    record = {
                        "phase": phase,
                        "iteration": int(iteration),
                        "episode": self.episode_counter,
                        "success": success[i],
                        "collision": contacts[i] > 0,
                        "collision_steps": contacts[i],
                        "out_of_bounds": out[i],
                        "timeout": truncated[i] and not success[i],
                        "length": lengths[i],
                        "expert_steps": experts[i],
                        "expert_control_steps": controls[i],
                        "expert_queries": asked[i],
                        "interventions": inters[i],
                        "start": [round(v, 4) for v in starts[i]],
                    }
                    if self.stage_names:  # the name, and its place in the task's order (records order themselves)
                        record["stage"] = self.stage_names[int(stage_reached[i])]
                        record["stage_index"] = int(stage_reached[i])
                    self.episode_counter += 1
                    stats.episodes_finished += 1
                    episode = Episode(record, env_index=i)
                    if self.keep_paths:
                        steps = paths[int(path_start[i]) :]
                        episode.positions = torch.cat([start_pos[i : i + 1], torch.stack([p[0][i] for p in steps])], 0)
                        episode.expert_mode = torch.stack([p[1][i] for p in steps])
                        episode.risk = torch.stack([p[2][i] for p in steps])
                        if self.stage_names:
                            episode.stage = torch.stack([p[3][i] for p in steps])  # type: ignore[index]
                    pending.flush(
                        self.replay_buffer, i, episode=record["episode"]
                    )  # the episode's frames reach the buffers as it is handed out
                    pending_experience.flush(self.experience_buffer, i)
                    yield episode
                    length[i] = expert_steps[i] = interventions[i] = contact_steps[i] = stage_reached[i] = 0
                    control_steps[i] = queries[i] = 0
                    path_start[i] = len(paths)
                    if rule.may_start(stats):
                        stats.episodes_started += 1
                    else:
                        active[i] = False
                if self.keep_paths and bool(active.any()):  # forget steps no running episode needs
                    cut = int(path_start[active].min())
                    paths, path_start = paths[cut:], path_start - cut
                if self.expert is not None:
                    self.expert.reset(td.get(("next", "done")).reshape(n))
                start_pos = torch.where(
                    td.get(("next", "done")).reshape(n, 1), td_next.get(self.position_key).reshape(n, -1), start_pos
                )
            td = td_next
        pending.flush(self.replay_buffer)  # nothing is left once every episode has ended; kept as a guard
        pending_experience.flush(self.experience_buffer)

    def _transitions(self, td: TensorDictBase, active: torch.Tensor) -> TensorDictBase:
        n, count = active.shape[0], int(active.sum())
        nxt = td.get("next")
        return TensorDict(
            {
                "observation": td.get(self.observation_key).reshape(n, -1)[active].clone(),
                "action": td.get("action").reshape(n, -1)[active].clone(),
                "next_observation": nxt.get(self.observation_key).reshape(n, -1)[active].clone(),
                "success": _flag(nxt, "success", n)[active].float().unsqueeze(-1),
                "done": _flag(nxt, "done", n)[active].float().unsqueeze(-1),
            },
            batch_size=[count],
        )

    def _expert_frames(self, td: TensorDictBase, mode: torch.Tensor, iteration: int) -> TensorDictBase:
        pos = td.get(self.position_key)[mode]
        next_pos = td.get(("next", self.position_key))[mode]
        count = int(mode.sum())
        return TensorDict(
            {
                "observation": td.get(self.observation_key)[mode].clone(),
                "expert_action": td.get("expert_action")[mode].clone(),
                "speed": ((next_pos - pos) ** 2).reshape(count, -1).sum(-1, keepdim=True),
                "iteration": torch.full((count,), int(iteration), dtype=torch.int64),
                # the collector's number of the frame's episode, set as the episode ends (held-out splits by episode)
                "episode": torch.full((count,), -1, dtype=torch.int64),
                # whether the expert drove this step: a label the robot's own motion carried (a gate's label
                # request) has the robot's speed, not the expert's, and the speed head must not learn it
                "expert_drove": td.get("expert_mode").reshape(mode.shape[0], -1)[mode].reshape(count).clone(),
            },
            batch_size=[count],
        )


class PendingFrames:
    """Frames of running episodes, with the env each row came from, until their episode ends."""

    def __init__(self) -> None:
        self.frames: list[TensorDictBase] = []
        self.envs: list[torch.Tensor] = []  # [rows] env index of each row of the matching frames

    def add(self, frames: TensorDictBase, envs: torch.Tensor) -> None:
        if frames.shape[0]:
            self.frames.append(frames)
            self.envs.append(envs)

    def flush(self, buffer: ReplayBuffer | None, env: int | None = None, episode: int | None = None) -> int:
        """Write the frames of ``env`` (None: all) to ``buffer`` in step order, in one extend; forget them.
        ``episode`` numbers them (frames with an ``episode`` field). Returns how many rows were written
        (or dropped, without a buffer)."""
        if not self.frames:
            return 0
        # torch.cat of tensordicts is tensordict's cat (torch's stubs take tensors only); a mask keeps a tensordict
        frames = cast(TensorDictBase, torch.cat(self.frames, 0))  # pyright: ignore[reportArgumentType]
        envs = torch.cat(self.envs, 0)
        take = torch.ones_like(envs, dtype=torch.bool) if env is None else envs == int(env)
        if buffer is not None and bool(take.any()):
            out = cast(TensorDictBase, frames[take])
            if episode is not None and "episode" in out.keys():
                out.set("episode", torch.full_like(out.get("episode"), int(episode)))
            buffer.extend(out)
        keep = ~take
        self.frames, self.envs = ([cast(TensorDictBase, frames[keep])], [envs[keep]]) if bool(keep.any()) else ([], [])
        return int(take.sum())


def run_episodes(collector: InterventionCollector, episodes: int, phase: str, iteration: int) -> list[Episode]:
    """Convenience: run ``episodes`` episodes and return them all."""
    return list(collector.rollout(EpisodeBudget(episodes), phase, iteration))
