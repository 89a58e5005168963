"""Read an offline wandb run (``<run_dir>/wandb/offline-run-*``) without a server or a login.

wandb writes every record of a run (its config, group, job type, history rows, summary, files) to
``run-<id>.wandb``: a LevelDB-style log of 32 KiB blocks (file header ``:W&B``, magic 0xBEE1,
version 0; each record: CRC-32 (4 bytes), length (2), type (1: full, 2: first, 3: middle, 4: last))
holding ``wandb_internal_pb2.Record`` protobufs. This module decodes it with wandb's own protobuf
classes, so a user (and the tests) can check what a dashboard will show before syncing.
"""

from __future__ import annotations

import json
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator

BLOCK = 32 * 1024
FILE_HEADER = struct.Struct("<4sHB")
RECORD_HEADER = struct.Struct("<IHB")
FULL, FIRST, MIDDLE, LAST = 1, 2, 3, 4


@dataclass
class OfflineRun:
    """What a dashboard would show for one offline run."""

    path: Path
    run_id: str = ""
    project: str = ""
    group: str = ""
    job_type: str = ""
    display_name: str = ""
    config: dict[str, Any] = field(default_factory=dict)
    history: list[dict[str, Any]] = field(default_factory=list)
    summary: dict[str, Any] = field(default_factory=dict)
    files: list[str] = field(default_factory=list)

    def history_keys(self) -> set[str]:
        return {k for row in self.history for k in row}

    def media(self, kind: str) -> list[Path]:
        """Media files of ``kind`` (``images`` or ``table``) written under the run's ``files/media``."""
        folder = self.path / "files" / "media" / kind
        return sorted(folder.rglob("*")) if folder.is_dir() else []


def _records(data: bytes) -> Iterator[bytes]:
    ident, magic, version = FILE_HEADER.unpack_from(data, 0)
    if ident != b":W&B" or magic != 0xBEE1 or version != 0:
        raise ValueError(
            f"not a wandb run file (header {ident!r}, magic {magic:#x}, version {version}): expected ':W&B', 0xBEE1, 0"
        )
    pos, pending = FILE_HEADER.size, b""
    while pos + RECORD_HEADER.size <= len(data):
        left_in_block = BLOCK - pos % BLOCK
        if left_in_block < RECORD_HEADER.size:  # the block's tail is zero padding
            pos += left_in_block
            continue
        _, length, kind = RECORD_HEADER.unpack_from(data, pos)
        pos += RECORD_HEADER.size
        chunk = data[pos : pos + length]
        pos += length
        if kind == FULL:
            yield chunk
        elif kind == FIRST:
            pending = chunk
        elif kind == MIDDLE:
            pending += chunk
        elif kind == LAST:
            yield pending + chunk
            pending = b""
        elif kind == 0 and length == 0:  # zero padding to the end of a block
            pos += BLOCK - pos % BLOCK if pos % BLOCK else 0
        else:
            raise ValueError(f"wandb run file: record type {kind} at byte {pos}: expected 1-4")


def _value(json_text: str) -> Any:
    try:
        return json.loads(json_text)
    except json.JSONDecodeError:
        return json_text


def _key(item: Any) -> str:
    return item.key or "/".join(item.nested_key)


def read_offline_run(run_path: str | Path) -> OfflineRun:
    """Decode ``run_path`` (an ``offline-run-*`` directory or its ``run-*.wandb`` file)."""
    from wandb.proto import wandb_internal_pb2 as pb  # noqa: PLC0415

    path = Path(run_path)
    files = [path] if path.is_file() else sorted(path.glob("run-*.wandb"))
    if not files:
        raise FileNotFoundError(
            f"run_path = {str(path)!r}: no run-*.wandb inside (expected a wandb offline-run-* directory)"
        )
    run = OfflineRun(path=files[0].parent)
    for raw in _records(files[0].read_bytes()):
        # protobuf builds wandb's message classes when the module loads: the checker cannot see them
        record = pb.Record()  # pyright: ignore[reportAttributeAccessIssue]
        record.ParseFromString(raw)
        kind = record.WhichOneof("record_type")
        if kind == "run":
            r = record.run
            run.run_id, run.project, run.group, run.job_type, run.display_name = (
                r.run_id,
                r.project,
                r.run_group,
                r.job_type,
                r.display_name,
            )
            for item in r.config.update:
                run.config[_key(item)] = _value(item.value_json)
        elif kind == "config":
            for item in record.config.update:
                run.config[_key(item)] = _value(item.value_json)
        elif kind == "history":
            run.history.append({_key(item): _value(item.value_json) for item in record.history.item})
        elif kind == "summary":
            for item in record.summary.update:
                run.summary[_key(item)] = _value(item.value_json)
        elif kind == "files":
            run.files += [f.path for f in record.files.files]
    return run


def offline_runs(root: str | Path) -> list[Path]:
    """Every ``offline-run-*`` directory below ``root``."""
    return sorted(p for p in Path(root).rglob("offline-run-*") if p.is_dir())
