"""The on-screen view of a simulated robot for a person teleoperating it (pad, keyboard, SpaceMouse).

A pygame window shows the simulation from one of its cameras (``env.render_frame``: MuJoCo's
offscreen renderer), under the same banner as the mouse window (who drives; a red "ROBOT ASKS FOR
HELP" with a beep when the gate hands over) and above the device's key help. It opens only where a
display exists; without one the session runs as before and the log says so. MuJoCo needs an OpenGL
context for the camera image: with a display, ``MUJOCO_GL=glfw`` (the default) gives one.

Rendering costs time (a software renderer under Xvfb takes ~0.1-0.3 s per 480x360 frame), so the image
is refreshed every ``every`` control steps; the banner is redrawn every step.
"""

from __future__ import annotations

import logging
import os
from typing import Any, Callable, Sequence

import numpy as np

from dpiil_rl.experts.base import SessionEnded
from dpiil_rl.experts.status_banner import BANNER_PX, banner_lines, draw_banner, make_beep

log = logging.getLogger(__name__)

HELP_LINE_PX = 24


def display_available() -> bool:
    """True where a window can be shown: an X or Wayland display, or SDL told to use a driver explicitly."""
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY") or os.environ.get("SDL_VIDEODRIVER"))


class SimView:
    """A window: banner, camera image ``width`` x ``height`` from ``frame()``, then ``help_lines``."""

    def __init__(
        self,
        frame: Callable[[], np.ndarray],
        width: int = 480,
        height: int = 360,
        every: int = 2,
        help_lines: Sequence[str] = (),
        title: str = "dpiil_rl · you are the expert",
        how_to_take_over: str = "press A, then hold B",
        sound: bool = True,
    ) -> None:
        if width < 64 or height < 48 or every < 1:
            raise ValueError(
                f"view width = {width}, height = {height}, every = {every}: expected at least 64 x 48 "
                "pixels and a refresh every >= 1 steps"
            )
        self.frame = frame
        self.width, self.height, self.every = int(width), int(height), int(every)
        self.help_lines = list(help_lines)
        self.title = title
        self.how_to_take_over = how_to_take_over
        self.sound = bool(sound)
        self.is_open = False
        self.frames_shown = 0
        self._steps = 0
        self._asked = False
        self._image: Any = None
        self._pygame: Any = None
        self._screen: Any = None
        self._font: Any = None
        self._beep: Any = None

    @property
    def size(self) -> tuple[int, int]:
        return self.width, BANNER_PX + self.height + HELP_LINE_PX * len(self.help_lines) + 6

    def open(self) -> bool:
        """Open the window; False (and a log line saying why) where there is no display."""
        import pygame  # noqa: PLC0415

        pygame.display.init()
        pygame.font.init()
        try:
            self._screen = pygame.display.set_mode(self.size)
        except pygame.error as err:
            log.warning(
                "no display for the simulation view (%s): the session goes on without it. Run on a desktop "
                "or under `xvfb-run` to see the robot.",
                err,
            )
            return False
        pygame.display.set_caption(self.title)
        self._font = pygame.font.SysFont(None, 24)
        self._pygame = pygame
        if self.sound:
            self._beep = make_beep(pygame)
        self.is_open = True
        return True

    def show(self, asking: bool, driving: bool, handover: str, risk: float | None, person_gates: bool = False) -> None:
        """Redraw: a new camera image every ``every`` calls, the banner and the help every call."""
        if not self.is_open:
            return
        pg, screen = self._pygame, self._screen
        if pg.event.get(pg.QUIT):
            raise SessionEnded("the simulation view was closed: the session ends, everything collected so far is kept")
        if asking and not self._asked and self._beep is not None:
            self._beep.play()
        self._asked = asking
        if self._steps % self.every == 0:
            image = np.ascontiguousarray(self.frame()[:, :, :3])
            if image.shape[:2] != (self.height, self.width):
                raise ValueError(f"view frame has shape {image.shape}: expected ({self.height}, {self.width}, 3)")
            self._image = pg.surfarray.make_surface(image.swapaxes(0, 1))
            self.frames_shown += 1
        self._steps += 1
        screen.fill((30, 30, 30))
        if self._image is not None:
            screen.blit(self._image, (0, BANNER_PX))
        draw_banner(
            pg,
            screen,
            self._font,
            self.width,
            banner_lines(asking, driving, handover, risk, self.how_to_take_over, person_gates),
        )
        for i, line in enumerate(self.help_lines):
            screen.blit(
                self._font.render(line, True, (230, 230, 230)), (10, BANNER_PX + self.height + 4 + HELP_LINE_PX * i)
            )
        pg.display.flip()

    def pixel(self, x: int, y: int) -> tuple[int, int, int]:
        """The window's colour at ``(x, y)`` (tests and screenshots)."""
        r, g, b, *_ = self._screen.get_at((int(x), int(y)))
        return int(r), int(g), int(b)

    def save(self, path: str) -> None:
        """Write the window's current content as a PNG."""
        self._pygame.image.save(self._screen, str(path))

    def close(self) -> None:
        if self._pygame is not None:
            self._pygame.display.quit()
            self._pygame = None
        self.is_open = False
