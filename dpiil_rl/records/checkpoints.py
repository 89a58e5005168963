"""The checkpoint format of a run directory: ``checkpoints/iter_XXX/{state.pt, buffer/[, experience/]}``,
``checkpoints/latest`` pointing at the newest complete one, ``checkpoints/pause`` for a session stopped inside an
iteration. Written atomically (a directory renamed into place, then the pointer), read back to resume or to
evaluate a policy later."""

from __future__ import annotations

import os
import shutil
import warnings
from pathlib import Path
from typing import Any, Mapping, Protocol

import torch
from torchrl.data import ReplayBuffer


class Checkpointable(Protocol):
    """What a checkpoint is written from: the trainer's state and its buffers by name."""

    def state_dict(self) -> dict[str, Any]: ...

    def buffers(self) -> Mapping[str, ReplayBuffer]: ...


LATEST = "latest"


def checkpoint_dir(run_dir: str | Path, iteration: int) -> Path:
    return Path(run_dir) / "checkpoints" / f"iter_{iteration:03d}"


def latest_checkpoint(run_dir: str | Path) -> Path | None:
    """The newest complete checkpoint of a run, or None."""
    pointer = Path(run_dir) / "checkpoints" / LATEST
    if not pointer.exists():
        return None
    path = Path(run_dir) / "checkpoints" / pointer.read_text().strip()
    return path if (path / "state.pt").exists() else None


def prune_checkpoints(run_dir: str | Path, keep: int) -> list[Path]:
    """Delete the iteration checkpoints of ``run_dir`` but iteration 0 (the initial maps the plots and
    ``study_maps`` read) and the newest ``keep`` complete ones; the one ``latest`` points at is always kept.
    Returns the deleted directories."""
    root = Path(run_dir) / "checkpoints"
    iterations = sorted(
        (int(p.name[len("iter_") :]), p)
        for p in root.glob("iter_*")
        if p.is_dir() and p.name[len("iter_") :].isdigit() and (p / "state.pt").exists()
    )
    latest = latest_checkpoint(run_dir)
    kept = {p for _, p in iterations[-keep:]} | {p for k, p in iterations if k == 0}
    removed = [p for _, p in iterations if p not in kept and p != latest]
    for path in removed:
        shutil.rmtree(path, ignore_errors=True)
    return removed


def load_state(path: str | Path) -> dict[str, Any]:
    return torch.load(Path(path) / "state.pt", map_location="cpu", weights_only=False)


PAUSE = "pause"  # the checkpoint of a session stopped in the middle of an iteration
EMPTY = ".empty"  # ``<name>.empty`` in a checkpoint: that buffer held no frame (torchrl cannot dump an empty storage)


def dump_buffer(buffer: ReplayBuffer, checkpoint: Path, name: str) -> None:
    """``checkpoint/<name>/``: the buffer's frames, or the marker ``<name>.empty`` when it has none (a session
    closed before its first expert-labelled step)."""
    if len(buffer) == 0:
        (checkpoint / f"{name}{EMPTY}").touch()
        return
    with warnings.catch_warnings():
        # a buffer loaded from a checkpoint and saved again before any new frame has no ``_last_cursor``;
        # torchrl warns because checkpointers with trajectory-reordering save hooks (Flat/Nested/H5) would
        # need it. The default TensorStorageCheckpointer used here has no save hooks: the dump is complete.
        warnings.filterwarnings("ignore", message="last_cursor is None", category=UserWarning)
        buffer.dumps(str(checkpoint / name))


def load_buffer(buffer: ReplayBuffer, checkpoint: str | Path, name: str) -> None:
    """Fill ``buffer`` from ``checkpoint/<name>/`` (left empty for a ``<name>.empty`` marker)."""
    checkpoint = Path(checkpoint)
    if (checkpoint / name).is_dir():
        buffer.loads(str(checkpoint / name))
    elif not (checkpoint / f"{name}{EMPTY}").exists():
        raise FileNotFoundError(
            f"checkpoint {str(checkpoint)!r}: no {name}/ inside (expected the dump of the run's "
            f"{name} buffer, or {name}{EMPTY} when it was empty)"
        )


def write_checkpoint(trainer: Checkpointable, final: Path) -> None:
    """Write ``final/{state.pt, buffer/[, experience/]}`` atomically, then point ``latest`` at it."""
    tmp = final.with_name(final.name + ".tmp")
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir(parents=True)
    torch.save(trainer.state_dict(), tmp / "state.pt")
    for name, buffer in trainer.buffers().items():
        dump_buffer(buffer, tmp, name)
    shutil.rmtree(final, ignore_errors=True)
    os.replace(tmp, final)
    pointer = final.parent / LATEST
    pointer_tmp = final.parent / (LATEST + ".tmp")
    pointer_tmp.write_text(final.name + "\n")
    os.replace(pointer_tmp, pointer)
