"""``expert=gamepad``: the A / B / Y protocol through the device layer, with a scripted pad."""

from types import SimpleNamespace
from typing import Any, cast

import pytest
import torch

from dpiil_rl.experts.device_teleop import AXIS_LY, BUTTON_A, BUTTON_B, BUTTON_X, BUTTON_Y, DeviceTeleopExpert, PadState
from dpiil_rl.experts.handover import Handover

# stand-ins: the ring env's action spec and batch size; a person's source reads no state
FAKE_RING: Any = SimpleNamespace(action_spec=SimpleNamespace(shape=torch.Size([1, 6])), batch_size=torch.Size([1]))
NO_STATE: Any = None
READER = {"_target_": "tests.mocks.scripted_pad.ScriptedPadReader"}


def _pad(*buttons, ly=0.0, connected=True):
    state = PadState(connected=connected)
    for b in buttons:
        state.buttons[b] = True
    state.axes[AXIS_LY] = ly
    return state


@pytest.fixture
def pad():
    src = DeviceTeleopExpert(FAKE_RING, reader=READER, speed=0.5, realtime=False)
    with src:
        yield src
    reader: Any = src.reader  # the scripted pad
    assert reader.closed == 1


def _step(src, state):
    src.reader.state = state
    src.observe(NO_STATE)
    return src.get_action(NO_STATE)


def test_button_sequence(pad):
    assert _step(pad, _pad(BUTTON_B, ly=-1.0))[0, :5].abs().max() == 0  # B before A: nothing moves
    _step(pad, _pad())
    _step(pad, _pad(BUTTON_A))  # A: sync
    assert pad.handover.state is Handover.SYNCED
    a = _step(pad, _pad(BUTTON_B, ly=-1.0))  # B held, stick forward: +x
    assert pad.handover.state is Handover.FOLLOWING and a[0, 0] == pytest.approx(0.5) and bool(pad.labelled[0])
    assert _step(pad, _pad(BUTTON_B, ly=-0.05))[0, 0] == 0  # inside the dead zone
    a = _step(pad, _pad(ly=-1.0))  # B released: stop
    assert pad.handover.state is Handover.STOPPED and a[0, :5].abs().max() == 0 and not bool(pad.labelled[0])
    _step(pad, _pad(BUTTON_B, ly=-1.0))  # B again without A: still stopped
    assert pad.handover.state is Handover.STOPPED
    _step(pad, _pad())
    _step(pad, _pad(BUTTON_Y))  # Y held: the policy runs
    assert pad.policy_requested
    _step(pad, _pad())
    assert pad.handover.state is Handover.STOPPED


def test_gripper_toggles_on_x(pad):
    assert float(_step(pad, _pad())[0, 5]) == -1.0
    assert float(_step(pad, _pad(BUTTON_X))[0, 5]) == 1.0
    assert float(_step(pad, _pad(BUTTON_X))[0, 5]) == 1.0  # held: no second toggle
    _step(pad, _pad())
    assert float(_step(pad, _pad(BUTTON_X))[0, 5]) == -1.0


def test_unplugged_pad_stops_the_robot_and_recovers(pad, caplog):
    _step(pad, _pad(BUTTON_A))
    _step(pad, _pad(BUTTON_B, ly=-1.0))
    a = _step(pad, _pad(connected=False))
    assert pad.handover.state is Handover.STOPPED and a[0, :5].abs().max() == 0
    assert "scripted pad lost" in caplog.text and "press A" in caplog.text
    _step(pad, _pad())  # plugged back in
    _step(pad, _pad(BUTTON_A))
    assert _step(pad, _pad(BUTTON_B, ly=-1.0))[0, 0] > 0


def test_wrong_task_is_named():
    with pytest.raises(ValueError, match="6-D end-effector"):
        DeviceTeleopExpert(
            cast(
                Any, SimpleNamespace(action_spec=SimpleNamespace(shape=torch.Size([1, 2])), batch_size=torch.Size([1]))
            ),
            reader=READER,
        )


def test_real_reader_without_a_pad_stops_safely(monkeypatch, caplog):
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    monkeypatch.setenv("SDL_JOYSTICK_DEVICE", "/nonexistent")
    pytest.importorskip("pygame")
    src = DeviceTeleopExpert(FAKE_RING)  # the default reader: pygame's joystick API; no pad on this machine
    with src:
        a = src.get_action(NO_STATE)
    assert src.labelled is not None and a[0, :5].abs().max() == 0 and not bool(src.labelled[0])
    assert "game pad #0 lost" in caplog.text


def test_hg_dagger_the_person_takes_over_with_a_then_b_and_hands_back_by_releasing_b(pad):
    free = torch.tensor([[False]])

    def gate(state):
        pad.reader.state = state
        return bool(pad.wants_control(None, free))

    assert not gate(_pad()) and not gate(_pad(BUTTON_B))  # B alone (not synced) takes nothing
    assert not gate(_pad()) and not gate(_pad(BUTTON_A))  # A syncs: the robot still drives
    assert gate(_pad(BUTTON_B)) and gate(_pad(BUTTON_B, ly=-1.0))  # B held: the person drives
    assert not gate(_pad())  # released: the robot drives again
    assert not gate(_pad(connected=False))  # a lost pad never holds control
