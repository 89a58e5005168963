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

    ``max_episodes`` guards against a policy so confident that the expert is never asked.
    """

    def __init__(self, pairs: int, max_episodes: int | None = None) -> None:
        if int(pairs) < 1:
            raise ValueError(f"expert_pairs_per_iteration = {pairs}: expected a positive number of pairs")
        if max_episodes is not None and int(max_episodes) < 1:
            raise ValueError(f"max_episodes_per_iteration = {max_episodes}: expected a positive number or null")
        self.pairs = int(pairs)
        self.max_episodes = None if max_episodes is None else int(max_episodes)

    def may_start(self, stats: RoundStats) -> bool:
        if self.max_episodes is not None and stats.episodes_started >= self.max_episodes:
            return False
        return stats.expert_pairs < self.pairs
