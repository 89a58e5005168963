"""``expert=ur5e_teleop``: the hand + pad protocol, its input-side safety, and a replayed session on the sim arm."""

import json
from types import SimpleNamespace
from typing import Any

import pytest
import torch
from hydra import compose, initialize_config_dir
from hydra.utils import instantiate
from tensordict import TensorDict

from dpiil_rl.envs.factory import make_env
from dpiil_rl.envs.shaft import ShaftEnv
from dpiil_rl.experts.device_teleop import BUTTON_A, BUTTON_B, BUTTON_Y, PadState
from dpiil_rl.experts.handover import Handover
from dpiil_rl.experts.ur5e_teleop import UR5eTeleopExpert
from dpiil_rl.robots.safety_log import SafetyEventKind
from tests.conftest import ROOT
from tests.mocks.held_mocap import HeldMocap
from tests.mocks.scripted_pad import ScriptedPadReader

ENV: Any = SimpleNamespace(  # a stand-in for a 3-D TCP task's env
    action_spec=SimpleNamespace(shape=torch.Size([1, 3])),
    batch_size=torch.Size([1]),
    geometry=SimpleNamespace(max_speed=0.25),
    position_key="tcp_pos",
)
LIMITS = {
    "low": [0.0, -0.5, 0.0],
    "high": [1.0, 0.5, 0.5],
    "max_speed": 0.25,
    "max_tracking_error": 0.05,
    "watchdog_timeout": 0.1,
}


@pytest.fixture
def teleop(tmp_path):
    src = UR5eTeleopExpert(
        ENV,
        mocap=HeldMocap(),
        pad=ScriptedPadReader(),
        limits=LIMITS,
        gain=4.0,
        safety_log=str(tmp_path / "safety_events.jsonl"),
        realtime=False,
    )
    with src:
        yield src


def _td(tcp):
    return TensorDict({"tcp_pos": torch.tensor([tcp], dtype=torch.float32)}, [1])


def _press(src, *buttons):
    state = PadState()
    for b in buttons:
        state.buttons[b] = True
    src.pad.state = state


def _kinds(src):
    return [e.kind for e in src.safety_log.events]


def test_sync_offset_follow_and_deadman(teleop):
    tcp = [0.4, 0.0, 0.2]
    teleop.mocap.put([1.0, 2.0, 3.0])  # the hand is far from the robot: the offset absorbs it
    _press(teleop, BUTTON_B)
    assert not teleop.get_action(_td(tcp)).any()  # B before A: nothing moves
    _press(teleop)
    teleop.get_action(_td(tcp))
    _press(teleop, BUTTON_A)
    assert not teleop.get_action(_td(tcp)).any() and teleop.handover.state is Handover.SYNCED  # no jump at sync
    _press(teleop, BUTTON_B)
    teleop.mocap.put([1.02, 2.0, 3.0])  # hand 2 cm forward: the robot follows forward
    action = teleop.get_action(_td(tcp))
    assert teleop.handover.moving and bool(teleop.labelled[0])
    assert action[0, 0] == pytest.approx(4.0 * 0.02 / 0.25) and action[0, 1:].abs().max() == 0
    _press(teleop)  # B released: stop (deadman)
    assert not teleop.get_action(_td(tcp)).any() and teleop.handover.state is Handover.STOPPED
    assert SafetyEventKind.DEADMAN in _kinds(teleop)
    _press(teleop, BUTTON_Y)
    teleop.get_action(_td(tcp))
    assert teleop.policy_requested


def _following(src, tcp):
    src.mocap.put(tcp)
    _press(src, BUTTON_A)
    src.get_action(_td(tcp))
    _press(src, BUTTON_A, BUTTON_B)
    src.get_action(_td(tcp))
    assert src.handover.moving


def test_stale_hand_stops_within_the_period_and_sync_is_refused(teleop):
    tcp = [0.4, 0.0, 0.2]
    _following(teleop, tcp)
    teleop.mocap.put([0.41, 0.0, 0.2], age=0.15)  # older than the 100 ms watchdog
    assert not teleop.get_action(_td(tcp)).any() and teleop.handover.state is Handover.STOPPED
    _press(teleop)
    teleop.get_action(_td(tcp))
    teleop.mocap.put(tcp, tracking_valid=False)  # tracker lost the ring: a sync is refused
    _press(teleop, BUTTON_A)
    teleop.get_action(_td(tcp))
    assert teleop.handover.state is Handover.STOPPED
    assert _kinds(teleop).count(SafetyEventKind.WATCHDOG) == 2


def test_tracking_error_is_a_protective_stop_until_resync(teleop, tmp_path):
    tcp = [0.4, 0.0, 0.2]
    _following(teleop, tcp)
    teleop.mocap.put([0.5, 0.0, 0.2])  # the hand ran 10 cm ahead of the robot
    assert not teleop.get_action(_td(tcp)).any() and teleop.handover.state is Handover.STOPPED
    _press(teleop, BUTTON_B)  # B alone does not restart it
    teleop.get_action(_td(tcp))
    assert teleop.handover.state is Handover.STOPPED
    teleop.disconnect()
    rows = [json.loads(line) for line in (tmp_path / "safety_events.jsonl").read_text().splitlines()]
    assert any(r["kind"] == "tracking_error" for r in rows)


def test_lost_pad_stops(teleop):
    tcp = [0.4, 0.0, 0.2]
    _following(teleop, tcp)
    teleop.pad.state = PadState(connected=False)
    assert not teleop.get_action(_td(tcp)).any() and teleop.handover.state is Handover.STOPPED
    assert SafetyEventKind.DEVICE_LOST in _kinds(teleop)


def test_wrong_env_is_named():
    env: Any = SimpleNamespace(action_spec=SimpleNamespace(shape=torch.Size([1, 6])), batch_size=torch.Size([1]))
    with pytest.raises(ValueError, match="3-D TCP velocity"):
        UR5eTeleopExpert(env, mocap=HeldMocap(), pad=ScriptedPadReader(), limits=LIMITS)


def test_replayed_session_drives_the_simulated_arm(tmp_path, monkeypatch):
    """`expert=ur5e_sim` on `env=shaft`: a recorded hand and button sequence reach the shaft on the sim arm."""
    monkeypatch.chdir(ROOT)
    with initialize_config_dir(config_dir=str(ROOT / "configs"), version_base=None):
        cfg = compose(
            "config",
            overrides=[
                "env=shaft",
                "expert=ur5e_sim",
                "env.start.noise=0.0",
                f"expert.safety_log={tmp_path / 'safety_events.jsonl'}",
            ],
        )
    env = make_env(cfg.env, num_envs=1, seed=0)
    assert isinstance(env, ShaftEnv)
    src = instantiate(cfg.expert, env=env, seed=0, _convert_="none")
    try:
        with src:
            td = env.reset()
            src.reset(torch.ones(1, dtype=torch.bool))
            labelled, done = [], False
            for _ in range(int(env.geometry.max_steps)):
                src.observe(td)
                td.set("action", src.get_action(td))
                labelled.append(bool(src.labelled[0]))
                td = env.step(td).get("next")
                if bool(td.get("done").any()):
                    done = True
                    break
            assert done and bool(td.get("success").any()) and not bool(td.get("collision").any())
            assert not any(labelled[:7]) and all(labelled[8:])  # nothing before B (0.4 s), then the person drives
            # the next episode replays the session again from its start
            td = env.reset()
            src.reset(torch.ones(1, dtype=torch.bool))
            assert src.handover.state is Handover.STOPPED and src.episode_time() == 0.0
    finally:
        env.close()
