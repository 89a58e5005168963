"""Held-out splits of the dataset D by episode: a gate's own model (SafeDAgger's safety classifier) is fitted
on episodes the policy was not fitted to, as in the originals.

Each episode is held out or not by a hash of its number and the run's ``salt`` (its seed), so the split is
stable as D grows: an episode held out once stays held out, and the policy's training set only gains
episodes from one iteration to the next (a split drawn afresh at every refit moved whole episodes in and
out of a small D and made the policy flip between refits).
"""

from __future__ import annotations

import numpy as np
import torch

_MASK = np.uint64(0xFFFFFFFFFFFFFFFF)


def episode_uniform(episode: np.ndarray, salt: int) -> np.ndarray:
    """A uniform number in [0, 1) per episode number (splitmix64 of ``salt`` and the number)."""
    with np.errstate(over="ignore"):
        z = (episode.astype(np.uint64) + np.uint64(int(salt) & 0xFFFFFFFF) * np.uint64(0x9E3779B97F4A7C15)) & _MASK
        z = ((z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)) & _MASK
        z = ((z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)) & _MASK
        z = z ^ (z >> np.uint64(31))
    return (z >> np.uint64(11)).astype(np.float64) / float(1 << 53)


def heldout_episodes(episode: torch.Tensor, fraction: float, salt: int) -> torch.Tensor:
    """``[n]`` bool: the frames of the episodes whose hash falls below ``fraction`` — at least one episode and
    at most all but one (none when D holds fewer than two episodes, or at fraction 0)."""
    episode = episode.reshape(-1)
    ids = torch.unique(episode)
    if not 0.0 < float(fraction) < 1.0 or ids.numel() < 2:
        return torch.zeros_like(episode, dtype=torch.bool)
    u = torch.from_numpy(episode_uniform(ids.numpy(), salt))
    held = u < float(fraction)
    if not bool(held.any()):
        held[int(torch.argmin(u))] = True
    if bool(held.all()):
        held[int(torch.argmax(u))] = False
    return torch.isin(episode, ids[held])
