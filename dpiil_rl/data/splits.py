"""Held-out splits of the dataset D by episode: a gate's own model (SafeDAgger's safety classifier) is fitted
on episodes the policy was not fitted to, as in the originals."""

from __future__ import annotations

import torch


def heldout_episodes(episode: torch.Tensor, fraction: float, generator: torch.Generator) -> torch.Tensor:
    """``[n]`` bool: the frames of ``round(fraction × episodes)`` episodes drawn with ``generator`` (at least
    one and at most all but one; none when D holds fewer than two episodes). Frames of one episode are
    neighbours in the state space, so holding out whole episodes keeps the held-out part honest."""
    episode = episode.reshape(-1)
    ids = torch.unique(episode)
    if not 0.0 < float(fraction) < 1.0 or ids.numel() < 2:
        return torch.zeros_like(episode, dtype=torch.bool)
    k = min(ids.numel() - 1, max(1, round(float(fraction) * ids.numel())))
    chosen = ids[torch.randperm(ids.numel(), generator=generator)[:k]]
    return torch.isin(episode, chosen)
