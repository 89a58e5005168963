"""``expert=mouse`` driven by synthetic pygame events on a headless display (SDL dummy driver)."""

import os

import pytest
import torch

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")
pygame = pytest.importorskip("pygame")

from dpiil_rl.envs.factory import make_env  # noqa: E402
from dpiil_rl.experts.handover import Handover  # noqa: E402
from dpiil_rl.experts.mouse import MouseLeaderExpert, SessionEnded  # noqa: E402


@pytest.fixture
def source(aperture_cfg):
    env = make_env(aperture_cfg, num_envs=1, seed=0)
    src = MouseLeaderExpert(env, realtime=False, sound=False)
    with src:
        td = env.reset()
        td["expert_mode"] = torch.tensor([[True]])
        yield src, td


def _post(kind, pos, **extra):
    pygame.event.post(pygame.event.Event(kind, pos=pos, **extra))


def test_grab_drag_release_regrab(source):
    src, td = source
    agent = td["observation"][0].tolist()
    here = src.to_px(*agent)
    _post(pygame.MOUSEBUTTONDOWN, here, button=1)
    a = src.get_action(td)
    assert src.handover.state is Handover.FOLLOWING and bool(src.labelled[0])
    assert a.abs().max() < 0.05  # grabbed where it is: no jump
    px_per_cm = src.to_px(1.0, 0.0)[0] - src.to_px(0.0, 0.0)[0]
    _post(pygame.MOUSEMOTION, (here[0] + round(0.3 * px_per_cm), here[1]), rel=(0, 0), buttons=(1, 0, 0))
    a = src.get_action(td)
    assert a[0, 0] == pytest.approx(0.3, abs=0.05) and abs(float(a[0, 1])) < 0.05  # the cursor's motion
    _post(pygame.MOUSEMOTION, (here[0] + round(5 * px_per_cm), here[1]), rel=(0, 0), buttons=(1, 0, 0))
    assert float(src.get_action(td)[0, 0]) == pytest.approx(src.geometry.max_speed)  # clipped to the task's limit
    _post(pygame.MOUSEBUTTONUP, here, button=1)
    a = src.get_action(td)
    assert src.handover.state is Handover.STOPPED and a.abs().max() == 0 and not bool(src.labelled[0])
    far = src.to_px(agent[0] + 5.0, agent[1] + 5.0)
    _post(pygame.MOUSEBUTTONDOWN, far, button=1)  # pressing elsewhere does not grab
    src.get_action(td)
    assert src.handover.state is Handover.STOPPED
    _post(pygame.MOUSEBUTTONUP, far, button=1)
    _post(pygame.MOUSEBUTTONDOWN, here, button=1)  # re-grab
    src.get_action(td)
    assert src.handover.state is Handover.FOLLOWING


def test_losing_the_window_stops_and_closing_ends(source):
    src, td = source
    here = src.to_px(*td["observation"][0].tolist())
    _post(pygame.MOUSEBUTTONDOWN, here, button=1)
    src.get_action(td)
    pygame.event.post(pygame.event.Event(pygame.WINDOWFOCUSLOST))
    assert src.get_action(td).abs().max() == 0 and src.handover.state is Handover.STOPPED
    src.observe(td)  # draws without error in every state
    pygame.event.post(pygame.event.Event(pygame.QUIT))
    with pytest.raises(SessionEnded):
        src.get_action(td)


def test_a_person_drives_one_robot(aperture_cfg):
    with pytest.raises(ValueError, match="interactive_envs = 4"):
        MouseLeaderExpert(make_env(aperture_cfg, num_envs=4), realtime=False)


def test_hg_dagger_pressing_on_the_robot_takes_over_and_releasing_hands_back(source):
    src, td = source
    free = torch.tensor([[False]])
    here = src.to_px(*td["observation"][0].tolist())
    assert not bool(src.wants_control(td, free)) and src.person_gates  # nobody holds it: the robot drives
    _post(pygame.MOUSEBUTTONDOWN, here, button=1)
    assert bool(src.wants_control(td, free))  # pressed on it: the person takes over
    _post(pygame.MOUSEBUTTONUP, here, button=1)
    assert not bool(src.wants_control(td, torch.tensor([[True]])))  # released: handed back
