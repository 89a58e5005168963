"""Every safety event of a session, kept in memory, appended to the run directory and logged as warnings.

A person who finds the arm stopped, or a reviewer of a study, needs to know what the safety layer did and
when. :class:`SafetyLog` records each event (a clip, a stop, a lost device) three ways: in memory (counts
for tests and the run summary), as one JSON line in ``<run dir>/safety_events.jsonl`` (every event, flushed
at once, so a crash loses nothing) and as a one-line ``logging`` warning. The warnings are rate-limited per
kind: a clip held for seconds gives one warning a second (with the number of repeats), not one per step.
"""

from __future__ import annotations

import enum
import json
import logging
import math
import time
from collections import Counter, deque
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import IO, Any

import numpy as np

from dpiil_rl.records.appends import recover_jsonl

log = logging.getLogger(__name__)

#: file name of the event log inside a run directory
EVENTS_FILE = "safety_events.jsonl"


class SafetyEventKind(enum.Enum):
    SPEED_CLIPPED = "speed_clipped"  # commanded speed above max_speed: scaled down
    ACCEL_CLIPPED = "accel_clipped"  # velocity change above max_acceleration * dt: ramped
    WORKSPACE_CLIPPED = "workspace_clipped"  # motion toward a wall reduced, or a move_to target moved into the box
    NON_FINITE = "non_finite"  # NaN / inf in a command or a reading: commanded a stop
    TRACKING_ERROR = "tracking_error"  # TCP too far from its target: protective stop latched
    WATCHDOG = "watchdog"  # input stream older than its timeout
    DEADMAN = "deadman"  # the person let go of the enabling button
    DEVICE_LOST = "device_lost"  # input device disconnected
    PROTECTIVE_STOP = "protective_stop"  # motion refused: the controller (or a latched stop) holds the arm
    STOP_CLEARED = "stop_cleared"  # a latched stop was reset (re-sync)


@dataclass(frozen=True)
class SafetyEvent:
    time: float  # s, wall clock (Unix time) when recorded
    kind: SafetyEventKind
    details: dict[str, Any] = field(default_factory=dict)
    robot_time: float | None = None  # s, the backend's clock (RobotState.time), when known

    def to_json(self) -> str:
        record = {"time": self.time, "robot_time": self.robot_time, "kind": self.kind.value, "details": self.details}
        return json.dumps(_jsonable(record), allow_nan=False)


def _jsonable(value: Any) -> Any:
    """Plain JSON values: arrays become lists, NaN and inf become strings (strict JSON has neither)."""
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return [_jsonable(v) for v in value.tolist()]
    if isinstance(value, enum.Enum):
        return value.value
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        number = float(value)
        return number if math.isfinite(number) else str(number)
    if value is None or isinstance(value, str):
        return value
    return repr(value)


class SafetyLog:
    """Records safety events; ``path`` (optional) receives one JSON line per event.

    ``warn_interval`` (s) is the shortest gap between two warnings of the same kind; the events in
    between are still recorded (memory and file) and counted in the next warning. ``memory`` bounds the
    events kept in memory (the oldest are dropped; :meth:`counts` stays exact).
    """

    def __init__(self, path: str | Path | None = None, warn_interval: float = 1.0, memory: int = 10_000) -> None:
        self.path = Path(path) if path is not None else None
        self.warn_interval = float(warn_interval)
        self._events: deque[SafetyEvent] = deque(maxlen=memory)
        self._counts: Counter[SafetyEventKind] = Counter()
        self._last_warning: dict[SafetyEventKind, float] = {}
        self._suppressed: Counter[SafetyEventKind] = Counter()
        self._file: IO[str] | None = None

    @classmethod
    def in_run_dir(cls, run_dir: str | Path, **kwargs: Any) -> SafetyLog:
        """The log of a run: ``<run_dir>/safety_events.jsonl``."""
        return cls(Path(run_dir) / EVENTS_FILE, **kwargs)

    # ---------------------------------------------------------------------------- recording
    def record(self, kind: SafetyEventKind, robot_time: float | None = None, **details: Any) -> SafetyEvent:
        """Record one event (memory, file, rate-limited warning) and return it."""
        event = SafetyEvent(time=time.time(), kind=kind, details=dict(details), robot_time=robot_time)
        self._events.append(event)
        self._counts[kind] += 1
        if self.path is not None:
            self._write(event)
        self._warn(event)
        return event

    def _write(self, event: SafetyEvent) -> None:
        if self._file is None:
            assert self.path is not None
            self.path.parent.mkdir(parents=True, exist_ok=True)
            recover_jsonl(self.path)  # a torn last line of an earlier session is dropped before appending
            self._file = self.path.open("a", encoding="utf-8")
        self._file.write(event.to_json() + "\n")
        self._file.flush()

    def _warn(self, event: SafetyEvent) -> None:
        now = time.monotonic()
        last = self._last_warning.get(event.kind)
        if last is not None and now - last < self.warn_interval:
            self._suppressed[event.kind] += 1
            return
        repeats = self._suppressed.pop(event.kind, 0)
        self._last_warning[event.kind] = now
        summary = ", ".join(f"{k}={_short(v)}" for k, v in event.details.items())
        more = f" (+{repeats} since the last warning)" if repeats else ""
        log.warning("safety: %s%s%s", event.kind.value, f": {summary}" if summary else "", more)

    # ---------------------------------------------------------------------------- reading
    @property
    def events(self) -> list[SafetyEvent]:
        """The events kept in memory, oldest first."""
        return list(self._events)

    def counts(self) -> dict[SafetyEventKind, int]:
        """How many events of each kind were recorded (all of them, also those dropped from memory)."""
        return dict(self._counts)

    def count(self, kind: SafetyEventKind) -> int:
        return self._counts[kind]

    # ---------------------------------------------------------------------------- lifecycle
    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None

    def __enter__(self) -> SafetyLog:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()


def _short(value: Any) -> str:
    """A compact rendering for the one-line warning."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_short(v) for v in value) + "]"
    if isinstance(value, (float, np.floating)):
        return f"{float(value):.4g}"
    return str(value)
