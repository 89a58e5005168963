"""``make_buffer``: the aggregate dataset D, a TensorDictReplayBuffer on memmap storage in the run dir."""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import cast

import numpy as np
import torch
from tensordict import TensorDictBase
from torchrl.data import LazyMemmapStorage, TensorDictReplayBuffer

from dpiil_rl.data.filled_rows_checkpointer import FilledRowsCheckpointer


def make_buffer(
    run_dir: str | Path, capacity: int, name: str = "buffer", config_key: str = "buffer.capacity"
) -> TensorDictReplayBuffer:
    """A buffer whose storage lives in ``<run_dir>/<name>`` (memory-mapped, survives inspection); its checkpoint
    dumps hold the frames written, not the whole capacity (:class:`FilledRowsCheckpointer`)."""
    if int(capacity) < 1:
        raise ValueError(f"{config_key} = {capacity}: expected a positive number of frames")
    scratch = Path(run_dir) / name
    if scratch.exists():
        shutil.rmtree(scratch)  # a fresh start or a resume: contents come from a checkpoint dump
    storage = LazyMemmapStorage(int(capacity), scratch_dir=str(scratch))
    return TensorDictReplayBuffer(storage=storage, batch_size=256, checkpointer=FilledRowsCheckpointer())


def buffer_contents(buffer: TensorDictReplayBuffer) -> TensorDictBase:
    """Every stored frame, in insertion order, as one TensorDict ``[len(buffer)]``."""
    n = len(buffer)
    if n == 0:
        raise ValueError("the replay buffer is empty: no expert-labelled frame has been collected")
    # the storage make_buffer gave the buffer (a slice reads a range of its rows)
    return cast(LazyMemmapStorage, buffer.storage).get(slice(0, n)).clone()


def canonical_order(data: TensorDictBase) -> torch.Tensor:
    """The permutation that sorts ``data``'s rows by their content (every leaf, keys in sorted order,
    compared column by column): two datasets holding the same frames in any order sort alike."""
    keys = sorted(data.keys(include_nested=True, leaves_only=True), key=str)
    columns = [data.get(k).reshape(data.shape[0], -1).double().numpy() for k in keys]
    table = np.concatenate(columns, axis=1)
    return torch.from_numpy(np.lexsort(table.T[::-1].copy()))


def training_data(buffer: TensorDictReplayBuffer) -> TensorDictBase:
    """Every stored frame in canonical order (:func:`canonical_order`), what every fit reads.

    A fit draws its minibatches by index, so on the same frames in another order it would draw other
    examples and end elsewhere: when frames reach the buffer (a collector detail) must not change a
    result. Sorted by content, a fit depends on the set of frames alone.
    """
    data = buffer_contents(buffer).exclude("index")  # the buffer's own slot numbers: the insertion order
    return data[canonical_order(data)]
