"""``FilledRowsCheckpointer``: a buffer dump that holds the frames written, not the storage's whole capacity.

torchrl's ``TensorStorageCheckpointer`` writes the storage as allocated: a buffer of capacity 200,000 holding
3,000 frames dumps 200,000 rows, most of them zeros, at every checkpoint (≈ 9 MB per aperture buffer, ≈ 50 MB
for ThriftyDAgger's experience buffer), so a study of thousands of runs filled a disk with zeros. This
checkpointer writes rows ``[0, len)`` only, in the same on-disk layout (a memory-mapped TensorDict and
``storage_metadata.json``), and reads back both its own dumps and torchrl's full-capacity ones.

The rows kept are the rows a fit reads: every fit takes the buffer's contents in canonical order
(``dpiil_rl.data.buffer.training_data``), and the writer's cursor is dumped by the writer itself, so a run
resumed from a compact dump continues exactly as one resumed from a full dump.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from tensordict import TensorDict
from torchrl.data.replay_buffers.checkpointers import TensorStorageCheckpointer

METADATA = "storage_metadata.json"


class FilledRowsCheckpointer(TensorStorageCheckpointer):
    """Dump and load a one-dimensional TensorDict storage's written rows ``[0, len)``."""

    def dumps(self, storage: Any, path: str | Path) -> None:
        path = Path(path)
        if not storage.initialized:
            raise RuntimeError("Cannot save a non-initialized storage.")
        if storage.ndim != 1 or self._save_hooks or int(storage._len) == 0:
            super().dumps(storage, path)  # the layouts this class does not cut: torchrl's own dump
            return
        path.mkdir(exist_ok=True)
        rows = int(storage._len)
        storage._storage[:rows].clone().memmap(path, copy_existing=True)
        with open(path / METADATA, "w") as file:
            json.dump({"metadata": {}, "is_pytree": False, "len": rows, "rows": rows}, file)

    def loads(self, storage: Any, path: str | Path) -> None:
        path = Path(path)
        with open(path / METADATA) as file:
            metadata = json.load(file)
        if metadata["is_pytree"] or storage.ndim != 1 or self._load_hooks:
            super().loads(storage, path)
            return
        rows = int(metadata["len"])
        saved = TensorDict.load_memmap(path)  # ``rows`` rows (a compact dump) or the whole capacity (torchrl's)
        if not storage.initialized:
            storage._init(saved[0])
        if rows:
            storage._storage[:rows].update_(saved[:rows])
        storage._len = rows
