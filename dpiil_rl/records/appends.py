"""Files a run appends to survive a torn last line.

A crash, a power loss or a full disk in the middle of a write leaves a partial last line (a record cut
short, or zero bytes the file system had allocated). Such a tail is dropped and the file rewritten without
it, with one line on stderr saying what was dropped; the run then goes back to its checkpoint's row counts.
A line that does not parse *before* the last one is not a torn write: the file was damaged otherwise, and
the error names the file, the line and the way out.
"""

from __future__ import annotations

import json
import os
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable


class DamagedRecord(ValueError):
    """A record file damaged before its last line (one clear line: the file, the line, what to do)."""


@dataclass
class Recovered:
    rows: list[Any]
    dropped_bytes: int = 0


def _parse_lines(path: Path, parse: Callable[[str], Any], way_out: str) -> Recovered:
    data = path.read_bytes()
    if not data:
        return Recovered([])
    lines = data.split(b"\n")
    complete, tail = lines[:-1], lines[-1]  # without a final newline the last piece is a write cut short
    rows: list[Any] = []
    for number, raw in enumerate(complete, 1):
        text = raw.decode("utf-8", errors="replace").strip("\x00").strip()
        if not text:
            continue
        try:
            rows.append(parse(text))
        except (ValueError, IndexError) as err:
            if number == len(complete) and not tail.strip(b"\x00").strip():
                # the last complete line itself is torn (a cut-short write followed by a newline, or zeros)
                return Recovered(rows, len(raw) + 1 + len(tail))
            raise DamagedRecord(
                f"{path}: line {number} is not a record ({err}); the file is damaged before its last "
                f"line, so what the run recorded after line {number - 1} is unknown. {way_out}"
            ) from None
    dropped = len(tail)
    for raw in reversed(complete):  # blank or zero-filled lines at the end: space a cut-short write left
        if raw.strip(b"\x00").strip():
            break
        dropped += len(raw) + 1
    return Recovered(rows, dropped)


def _rewrite(path: Path, lines: list[str]) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text("".join(line + "\n" for line in lines))
    os.replace(tmp, path)


def recover_jsonl(path: str | Path, way_out: str = "") -> list[dict[str, Any]]:
    """The rows of a JSON-lines file, a torn last line dropped (the file rewritten without it, a line on stderr)."""
    path = Path(path)
    if not path.exists():
        return []
    way_out = way_out or (f"Restore {path.name} from a copy, or start the run over with overwrite=true.")
    got = _parse_lines(path, json.loads, way_out)
    if got.dropped_bytes:
        _rewrite(path, [json.dumps(r) for r in got.rows])
        print(
            f"[dpiil_rl] {path}: dropped a torn last line "
            f"({got.dropped_bytes} bytes, a write cut short by a crash or a "
            f"full disk); kept {len(got.rows)} rows",
            file=sys.stderr,
        )
    return got.rows


def _csv_row(text: str) -> tuple[int, str]:
    step, value = text.split(",", 1)
    return int(step), value


def trim_csv_log(path: str | Path, steps_below: int) -> None:
    """A ``step,value`` log (TorchRL's CSV logger) without a torn tail and without the rows of steps
    ``>= steps_below`` (logged after the checkpoint the run resumes from)."""
    path = Path(path)
    if not path.exists():
        return
    got = _parse_lines(
        path, _csv_row, f"Delete {path.name} (the dashboard's CSV copy) or start the run over with overwrite=true."
    )
    kept = [(s, v) for s, v in got.rows if s < int(steps_below)]
    if got.dropped_bytes or len(kept) != len(got.rows):
        _rewrite(path, [f"{s},{v}" for s, v in kept])
        if got.dropped_bytes:
            print(f"[dpiil_rl] {path}: dropped a torn last line ({got.dropped_bytes} bytes)", file=sys.stderr)
