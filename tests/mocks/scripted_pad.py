"""Test-only game pad: the test sets ``state`` (axes, buttons, connected) before each step."""

from __future__ import annotations

from dpiil_rl.experts.device_teleop import PadState


class ScriptedPadReader:
    def __init__(self) -> None:
        self.name = "scripted pad"
        self.state = PadState()
        self.opened = self.closed = 0

    def open(self) -> None:
        self.opened += 1

    def read(self) -> PadState:
        return self.state

    def close(self) -> None:
        self.closed += 1
