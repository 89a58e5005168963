"""Test-only: run ``dpiil-train`` in this process with one fault injected at a chosen point.

``python -m tests.mocks.fault_injector '<spec json>' <dpiil-train overrides...>`` where the spec is
``{"fault": "kill" | "enospc" | "count", "n": <the n-th instrumented operation, 1-based>}``. The instrumented
operations are every write a run makes to its directory, in order:

- ``append``: a row appended to episodes.jsonl / metrics.jsonl / paths.jsonl (a kill there writes the first
  half of the line, flushes it and dies: a torn line);
- ``save``: ``torch.save`` of a checkpoint's state (a kill writes half the file);
- ``dump``: a replay buffer's dump into a checkpoint (a kill dies half-way: after the dump, before the rest);
- ``replace``: the atomic renames of a checkpoint directory and of its ``latest`` pointer (a kill dies just
  before the rename).

``kill`` sends SIGKILL to the process at operation n (nothing is flushed or closed: as a power cut).
``enospc`` makes operation n and every later write fail with ``OSError(ENOSPC)`` (a full disk).
``count`` injects nothing and prints ``FAULT-SITES <total> <kinds>`` at the end (to choose n at random).
"""

from __future__ import annotations

import errno
import json
import os
import runpy
import signal
import sys
from pathlib import Path
from typing import Any, Callable

ROOT = Path(__file__).resolve().parents[2]


class Injector:
    def __init__(self, fault: str, n: int) -> None:
        self.fault, self.n = fault, int(n)
        self.count = 0
        self.kinds: list[str] = []
        self.full = False

    def hit(self, kind: str) -> bool:
        """Count one operation; True when the fault must strike now."""
        if self.full:
            raise OSError(errno.ENOSPC, "No space left on device (injected)")
        self.count += 1
        self.kinds.append(kind)
        if self.fault == "enospc" and self.count >= self.n:
            self.full = True
            raise OSError(errno.ENOSPC, "No space left on device (injected)")
        return self.fault == "kill" and self.count == self.n


def _die() -> None:
    os.kill(os.getpid(), signal.SIGKILL)


def install(injector: Injector) -> None:
    import torch

    from dpiil_rl.records import checkpoints as checkpoint
    from dpiil_rl.records import run_files

    original_append: Callable[..., Any] = run_files.RunFiles._append

    def append(path: Path, row: dict[str, Any]) -> None:
        if injector.hit("append"):
            line = json.dumps(run_files.clean_json(row)) + "\n"
            with Path(path).open("a") as f:
                f.write(line[: len(line) // 2])
                f.flush()
            _die()
        original_append(path, row)

    run_files.RunFiles._append = staticmethod(append)  # type: ignore[method-assign]

    original_save = torch.save

    def save(obj: Any, f: Any, *args: Any, **kwargs: Any) -> None:
        if injector.hit("save"):
            original_save(obj, f, *args, **kwargs)
            size = os.path.getsize(f)
            with open(f, "r+b") as fh:
                fh.truncate(size // 2)
            _die()
        original_save(obj, f, *args, **kwargs)

    checkpoint.torch.save = save  # type: ignore[attr-defined]

    original_dump = checkpoint.dump_buffer

    def dump(buffer: Any, ckpt: Path, name: str) -> None:
        strike = injector.hit("dump")
        original_dump(buffer, ckpt, name)
        if strike:
            _die()

    checkpoint.dump_buffer = dump  # type: ignore[assignment]

    original_replace = os.replace

    def replace(src: Any, dst: Any, *args: Any, **kwargs: Any) -> None:
        if "checkpoints" in str(dst) and injector.hit("replace"):
            _die()
        original_replace(src, dst, *args, **kwargs)

    checkpoint.os.replace = replace  # type: ignore[attr-defined]


def main() -> None:
    spec = json.loads(sys.argv[1])
    injector = Injector(spec["fault"], spec.get("n", 0))
    sys.path.insert(0, str(ROOT))
    install(injector)
    sys.argv = ["dpiil-train", *sys.argv[2:]]
    try:
        runpy.run_module("dpiil_rl.cli.train", run_name="__main__")
    finally:
        if spec["fault"] == "count":
            print(f"FAULT-SITES {injector.count} {','.join(sorted(set(injector.kinds)))}", flush=True)


if __name__ == "__main__":
    main()
