"""A recorded button sequence played back as a game pad (the hands-free side of a replayed session).

With :class:`~dpiil_rl.mocap.replay.ReplayMocap` for the hand, it lets the UR5e teleoperation run with no
person at all: in simulation (``make teleop ENV=shaft EXPERT=ur5e_sim``), in tests, or to repeat a
recorded session. The file is a CSV with a header: ``t`` (s, increasing) and any of the button columns
``a, b, x, y`` (0/1); each row holds until the next. Time runs on ``clock`` (default: real time since
:meth:`open`); a teleop expert that replays per episode sets ``clock`` to the episode's time and calls
:meth:`open` again at every episode start.
"""

from __future__ import annotations

import csv
import time
from pathlib import Path
from typing import Callable

import numpy as np

from dpiil_rl.experts.device_teleop import BUTTON_A, BUTTON_B, BUTTON_X, BUTTON_Y, PadState

BUTTON_COLUMNS = {"a": BUTTON_A, "b": BUTTON_B, "x": BUTTON_X, "y": BUTTON_Y}


class ReplayPadReader:
    """Buttons from a recorded CSV, as a :class:`~dpiil_rl.experts.device_teleop.PadReader`."""

    def __init__(self, path: str | Path, clock: Callable[[], float] | None = None) -> None:
        self.path = Path(path)
        self.name = f"replayed buttons ({self.path.name})"
        self.clock: Callable[[], float] = time.monotonic if clock is None else clock
        self._t, self._buttons = self._load()
        self._start = 0.0

    def _load(self) -> tuple[np.ndarray, dict[int, np.ndarray]]:
        if not self.path.is_file():
            raise FileNotFoundError(f"button recording {self.path}: no such file")
        with self.path.open(newline="") as handle:
            rows = list(csv.DictReader(handle))
        if not rows or "t" not in rows[0]:
            raise ValueError(
                f"button recording {self.path}: expected a CSV header with 't' and any of {sorted(BUTTON_COLUMNS)}"
            )
        unknown = set(rows[0]) - {"t", *BUTTON_COLUMNS}
        if unknown:
            raise ValueError(
                f"button recording {self.path}: unknown columns {sorted(unknown)}; "
                f"expected t, {', '.join(BUTTON_COLUMNS)}"
            )
        t = np.array([float(r["t"]) for r in rows])
        if np.any(np.diff(t) <= 0):
            bad = int(np.argmax(np.diff(t) <= 0)) + 2
            raise ValueError(f"button recording {self.path}: time does not increase at data row {bad}")
        buttons = {
            BUTTON_COLUMNS[c]: np.array([float(r[c]) > 0.5 for r in rows]) for c in rows[0] if c in BUTTON_COLUMNS
        }
        return t - t[0], buttons

    def open(self) -> None:
        """Start (or restart) playback at the first row."""
        self._start = self.clock()

    def read(self) -> PadState:
        elapsed = self.clock() - self._start
        row = int(np.clip(np.searchsorted(self._t, elapsed, side="right") - 1, 0, len(self._t) - 1))
        state = PadState()
        for button, column in self._buttons.items():
            state.buttons[button] = bool(column[row])
        return state

    def close(self) -> None:
        pass
