"""``make_buffer``: the aggregate dataset D, a TensorDictReplayBuffer on memmap storage in the run dir."""

from __future__ import annotations

import shutil
from pathlib import Path

from tensordict import TensorDictBase
from torchrl.data import LazyMemmapStorage, TensorDictReplayBuffer


def make_buffer(
    run_dir: str | Path, capacity: int, name: str = "buffer", config_key: str = "buffer.capacity"
) -> TensorDictReplayBuffer:
    """A buffer whose storage lives in ``<run_dir>/<name>`` (memory-mapped, survives inspection)."""
    if int(capacity) < 1:
        raise ValueError(f"{config_key} = {capacity}: expected a positive number of frames")
    scratch = Path(run_dir) / name
    if scratch.exists():
        shutil.rmtree(scratch)  # a fresh start or a resume: contents come from a checkpoint dump
    return TensorDictReplayBuffer(storage=LazyMemmapStorage(int(capacity), scratch_dir=str(scratch)), batch_size=256)


def buffer_contents(buffer: TensorDictReplayBuffer) -> TensorDictBase:
    """Every stored frame, in insertion order, as one TensorDict ``[len(buffer)]``."""
    n = len(buffer)
    if n == 0:
        raise ValueError("the replay buffer is empty: no expert-labelled frame has been collected")
    return buffer.storage.get(slice(0, n)).clone()
