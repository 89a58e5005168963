"""Read sizes and scales from TorchRL specs (never from configs)."""

from __future__ import annotations

from typing import Any

import torch


def spec_bounds(spec: Any) -> tuple[torch.Tensor, torch.Tensor]:
    """``(low, high)`` of one item of a bounded spec ``[*batch, dim]``, as float vectors ``[dim]``."""
    low, high = spec.space.low, spec.space.high
    return low.reshape(-1, low.shape[-1])[0].float(), high.reshape(-1, high.shape[-1])[0].float()
