"""The on-screen view of a simulated robot: banner, camera image, key help, closing, and a real ring render."""

import os
import subprocess
import sys
import textwrap
import time
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
import torch
from tensordict import TensorDict

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
pygame = pytest.importorskip("pygame")

from dpiil_rl.experts.base import SessionEnded  # noqa: E402
from dpiil_rl.experts.device_readers import PygameKeyboardReader  # noqa: E402
from dpiil_rl.experts.device_teleop import DeviceTeleopExpert  # noqa: E402
from dpiil_rl.experts.handover import Handover  # noqa: E402
from dpiil_rl.experts.sim_view import SimView  # noqa: E402
from dpiil_rl.experts.status_banner import ASKING_COLOUR, AUTO_COLOUR, BANNER_PX, DRIVING_COLOUR  # noqa: E402
from tests.conftest import ROOT  # noqa: E402
from tests.system_packages import find_or_install  # noqa: E402

GREEN = (20, 200, 60)


class FrameCounter:
    """A camera that returns a flat colour and counts how often it was asked."""

    def __init__(self, width, height):
        self.calls = 0
        self.image = np.zeros((height, width, 3), dtype=np.uint8)
        self.image[:] = GREEN

    def __call__(self, *args):
        self.calls += 1
        return self.image


def test_view_draws_image_banner_and_closes():
    camera = FrameCounter(160, 120)
    view = SimView(camera, 160, 120, every=2, help_lines=["A: sync"], sound=False)
    assert view.open()
    try:
        view.show(asking=False, driving=False, handover="stopped", risk=0.1)
        assert view.pixel(80, BANNER_PX + 60) == GREEN and view.pixel(2, 2) == AUTO_COLOUR
        view.show(asking=True, driving=False, handover="stopped", risk=0.9)
        assert view.pixel(2, 2) == ASKING_COLOUR
        view.show(asking=True, driving=True, handover="following", risk=0.9)
        assert view.pixel(2, 2) == DRIVING_COLOUR
        assert camera.calls == 2 and view.frames_shown == 2  # a new image every 2nd step
        pygame.event.post(pygame.event.Event(pygame.QUIT))
        with pytest.raises(SessionEnded):
            view.show(asking=False, driving=False, handover="stopped", risk=None)
    finally:
        view.close()


def test_bad_view_size_is_named():
    with pytest.raises(ValueError, match="width = 10"):
        SimView(lambda: np.zeros((120, 10, 3), dtype=np.uint8), 10, 120)


def _key(kind, key):
    pygame.event.post(pygame.event.Event(kind, key=key, mod=0, unicode="", scancode=0))


def test_keyboard_drives_from_the_view_window():
    camera = FrameCounter(200, 150)
    env: Any = SimpleNamespace(  # a stand-in for the ring env with a camera
        action_spec=SimpleNamespace(shape=torch.Size([1, 6])), batch_size=torch.Size([1]), render_frame=camera
    )
    src = DeviceTeleopExpert(
        env,
        reader=PygameKeyboardReader(),
        speed=0.5,
        dead_zone=0.0,
        view=True,
        view_size=(200, 150),
        view_every=1,
        sound=False,
        control_hz=50.0,
    )
    td = TensorDict({"expert_mode": torch.ones(1, 1, dtype=torch.bool), "risk": torch.full((1, 1), 0.5)}, [1])
    with src:
        assert (
            src.view is not None
            and src.view.is_open
            and isinstance(src.reader, PygameKeyboardReader)
            and src.reader._screen is None
        )  # one window: the view's
        _key(pygame.KEYDOWN, pygame.K_RETURN)
        src.observe(td)
        _key(pygame.KEYUP, pygame.K_RETURN)
        _key(pygame.KEYDOWN, pygame.K_SPACE)
        _key(pygame.KEYDOWN, pygame.K_w)
        start = time.monotonic()
        for _ in range(5):
            src.observe(td)
        paced = time.monotonic() - start
        action = src.get_action(td)
        assert src.handover.state is Handover.FOLLOWING and float(action[0, 0]) == pytest.approx(0.5)
        assert src.view.pixel(2, 2) == DRIVING_COLOUR and camera.calls == 6
        assert paced >= 4 * 0.02 - 1e-3  # real time: 50 Hz steps
        pygame.event.post(pygame.event.Event(pygame.QUIT))  # closing the view ends the session
        with pytest.raises(SessionEnded):
            src.observe(td)


RING_VIEW = textwrap.dedent("""
    import sys
    import numpy as np
    from omegaconf import OmegaConf
    from tensordict import TensorDict
    import torch
    from dpiil_rl.envs.factory import make_env
    from dpiil_rl.experts.device_teleop import DeviceTeleopExpert
    env = make_env(OmegaConf.load("configs/env/ring.yaml"), num_envs=1, seed=0)
    td = env.reset()
    src = DeviceTeleopExpert(env, reader={"_target_": "tests.mocks.scripted_pad.ScriptedPadReader"}, view=True,
                             view_size=(240, 180), view_every=1, sound=False, realtime=False)
    with src:
        td.set("expert_mode", torch.ones(1, 1, dtype=torch.bool))
        src.observe(td)
        src.view.save(sys.argv[1])
    env.close()
""")


def test_ring_view_on_a_virtual_screen(tmp_path):
    """The real thing: robosuite's camera through MuJoCo's renderer into the pygame window on an X server."""
    xvfb = find_or_install("Xvfb", "xvfb")
    display = ":93"
    server = subprocess.Popen(
        [xvfb, display, "-screen", "0", "640x480x24", "-nolisten", "tcp"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        time.sleep(1.0)
        shot = tmp_path / "ring_view.png"
        env = {k: v for k, v in os.environ.items() if k not in ("SDL_VIDEODRIVER", "MUJOCO_GL")}
        env.update(DISPLAY=display, SDL_AUDIODRIVER="dummy", PYTHONPATH=str(ROOT))
        proc = subprocess.run(
            [sys.executable, "-c", RING_VIEW, str(shot)], cwd=ROOT, env=env, capture_output=True, text=True, timeout=300
        )
        assert proc.returncode == 0, proc.stderr[-2000:]
    finally:
        server.terminate()
        server.wait(timeout=10)
    image = pygame.image.load(str(shot))
    pixels = pygame.surfarray.array3d(image).swapaxes(0, 1)
    scene = pixels[BANNER_PX : BANNER_PX + 180]
    assert tuple(pixels[2, 2]) == ASKING_COLOUR
    assert scene.std() > 20 and len(np.unique(scene.reshape(-1, 3), axis=0)) > 200  # a rendered scene, not a flat fill
