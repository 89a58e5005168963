"""When a collection round stops starting new episodes (episodes in progress always finish)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol


@dataclass
class RoundStats:
    """Counters of one collection round."""

    episodes_started: int = 0
    episodes_finished: int = 0
    expert_pairs: int = 0  # expert-labelled frames of active episodes
    steps: int = 0  # frames of active episodes


class StopRule(Protocol):
    def may_start(self, stats: RoundStats) -> bool:
        """Whether a new episode may start given the round so far."""
        ...


class EpisodeBudget:
    """Run exactly ``episodes`` episodes (demonstrations, evaluation)."""

    def __init__(self, episodes: int) -> None:
        if int(episodes) < 1:
            raise ValueError(f"episodes = {episodes}: expected at least one episode")
        self.episodes = int(episodes)

    def may_start(self, stats: RoundStats) -> bool:
        return stats.episodes_started < self.episodes


class ExpertPairQuota:
    """Start episodes until ``pairs`` expert-labelled frames are collected (paper: 200 per iteration).

    With several envs side by side, a new episode starts only if the pairs collected so far plus
    those expected from the episodes in progress stay below the quota (expected per episode: this
    round's mean once an episode has finished, else ``expected_per_episode``, which the loop sets
    from the previous round of the same kind). With one env nothing is in progress when it asks,
    so the rule is exactly "collect until the quota is met, finish the episode".

    ``max_episodes`` guards against a policy so confident that the expert is never asked.
    """

    def __init__(self, pairs: int, max_episodes: int | None = None) -> None:
        if int(pairs) < 1:
            raise ValueError(f"expert_pairs_per_iteration = {pairs}: expected a positive number of pairs")
        if max_episodes is not None and int(max_episodes) < 1:
            raise ValueError(f"max_episodes_per_iteration = {max_episodes}: expected a positive number or null")
        self.pairs = int(pairs)
        self.max_episodes = None if max_episodes is None else int(max_episodes)
        self.expected_per_episode = 0.0

    def may_start(self, stats: RoundStats) -> bool:
        if self.max_episodes is not None and stats.episodes_started >= self.max_episodes:
            return False
        in_progress = stats.episodes_started - stats.episodes_finished
        per_episode = (
            stats.expert_pairs / stats.episodes_finished if stats.episodes_finished else self.expected_per_episode
        )
        return stats.expert_pairs + in_progress * per_episode < self.pairs
