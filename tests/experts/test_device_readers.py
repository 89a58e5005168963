"""Keyboard and SpaceMouse readers produce the pad layout the hand-over protocol reads."""

import os
from types import SimpleNamespace
from typing import Any

import pytest
import torch

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
pygame = pytest.importorskip("pygame")

from dpiil_rl.experts.device_readers import PygameKeyboardReader, SpaceMouseReader  # noqa: E402
from dpiil_rl.experts.device_teleop import AXIS_LY, BUTTON_A, BUTTON_B, BUTTON_X, DeviceTeleopExpert  # noqa: E402
from dpiil_rl.experts.handover import Handover  # noqa: E402

# stand-ins: the ring env's action spec and batch size; a person's source reads no state
FAKE_RING: Any = SimpleNamespace(action_spec=SimpleNamespace(shape=torch.Size([1, 6])), batch_size=torch.Size([1]))
NO_STATE: Any = None


def _key(kind, key):
    pygame.event.post(pygame.event.Event(kind, key=key, mod=0, unicode="", scancode=0))


def test_keyboard_session():
    src = DeviceTeleopExpert(FAKE_RING, reader=PygameKeyboardReader(), speed=0.5, dead_zone=0.0)
    with src:
        _key(pygame.KEYDOWN, pygame.K_RETURN)
        src.get_action(NO_STATE)
        _key(pygame.KEYUP, pygame.K_RETURN)
        _key(pygame.KEYDOWN, pygame.K_SPACE)
        _key(pygame.KEYDOWN, pygame.K_w)
        a = src.get_action(NO_STATE)
        assert src.handover.state is Handover.FOLLOWING and float(a[0, 0]) == pytest.approx(0.5)
        _key(pygame.KEYUP, pygame.K_SPACE)
        assert src.get_action(NO_STATE)[0, :5].abs().max() == 0 and src.handover.state is Handover.STOPPED
        pygame.event.post(pygame.event.Event(pygame.QUIT))
        src.get_action(NO_STATE)  # the key window closed: a lost device, the robot stays still
        assert src.handover.state is Handover.STOPPED


def test_a_quick_tap_between_two_reads_counts():
    src = DeviceTeleopExpert(FAKE_RING, reader=PygameKeyboardReader(), speed=0.5, dead_zone=0.0)
    with src:
        _key(pygame.KEYDOWN, pygame.K_RETURN)
        _key(pygame.KEYUP, pygame.K_RETURN)  # pressed and released while the last step was rendering
        src.get_action(NO_STATE)
        assert src.handover.state is Handover.SYNCED


class FakeHid:
    def __init__(self, reports):
        self.reports = list(reports)

    def read(self, size):
        return self.reports.pop(0) if self.reports else []

    def close(self):
        pass


def test_spacemouse_reports():
    reader = SpaceMouseReader()
    reader._device = FakeHid([[1, 94, 1, 0, 0, 0, 0], [3, 1]])  # +350 counts in x, left button down
    state = reader.read()
    assert state.axes[AXIS_LY] == pytest.approx(-1.0) and state.buttons[BUTTON_A] and state.buttons[BUTTON_B]
    reader._device = FakeHid([[3, 2]])
    state = reader.read()
    assert state.buttons[BUTTON_X] and not state.buttons[BUTTON_B]


def test_spacemouse_absent_is_a_lost_device(caplog):
    reader = SpaceMouseReader()
    reader.open()  # no hid package or no device here
    assert not reader.read().connected
    assert "SpaceMouse" in caplog.text
