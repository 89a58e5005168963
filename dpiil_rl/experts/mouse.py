"""``expert=mouse``: a person drives the 2D aperture agent with the mouse (leader-following).

A pygame window draws the arena, the walls, the goal, the agent, the cursor, who is in control and
the robot's current risk. When the robot hands over it says so (red banner, text, optional beep).
The person grabs the agent by pressing on it (*sync*: the grab offset is kept, so control starts
without a jump), drags it (*follow*: the commanded velocity is the motion of the grabbed point,
clipped to the task's speed limit) and releases it (*stop*: the agent holds still until the next
grab). The loop runs in real time at ``control_hz``, so the person's own speed is what the speed head
learns. Only steps where the person actually drives are demonstrations (:attr:`labelled`). With
``method=hg_dagger`` the person decides when to take over: pressing on the robot takes it, releasing
hands it back (:meth:`wants_control`).

Closing the window raises :class:`SessionEnded`; losing the window (focus, pointer leaving it)
stops the agent. Without a display, :meth:`connect` says how to get one.
"""

from __future__ import annotations

import math
from typing import Any

import torch
from tensordict import TensorDictBase
from torchrl.envs import EnvBase

from dpiil_rl.experts.base import DeviceUnavailable, ExpertSource, SessionEnded, check_person_env
from dpiil_rl.experts.handover import Handover, HandoverEvent, HandoverMachine
from dpiil_rl.experts.status_banner import AUTO_COLOUR, BANNER_PX, DRIVING_COLOUR, banner_lines, draw_banner, make_beep

__all__ = ["DeviceUnavailable", "MouseLeaderExpert", "SessionEnded"]


class MouseLeaderExpert(ExpertSource):
    labels_every_step = False  # a person's input means something only while they drive

    def __init__(
        self,
        env: EnvBase,
        seed: int = 0,
        window_px: int = 640,
        control_hz: float = 20.0,
        realtime: bool = True,
        grab_radius: float = 1.0,
        sound: bool = True,
        observation_key: str = "observation",
    ) -> None:
        super().__init__()
        del seed  # a person needs no random stream
        geometry = getattr(env, "geometry", None)
        if geometry is None or not hasattr(geometry, "arena"):
            raise ValueError(
                f"expert=mouse drives a 2D task with an arena (env=aperture); env {type(env).__name__} has none"
            )
        check_person_env(env, "mouse")
        if control_hz <= 0 or window_px < 100 or grab_radius <= 0:
            raise ValueError(
                f"expert.control_hz = {control_hz}, window_px = {window_px}, grab_radius = {grab_radius}: "
                "expected a positive rate, at least 100 px and a positive grab radius (cm)"
            )
        self.geometry = geometry
        self.window_px = int(window_px)
        self.control_hz = float(control_hz)
        self.realtime = bool(realtime)
        self.grab_radius = float(grab_radius)
        self.sound = bool(sound)
        self.observation_key = observation_key
        self.handover = HandoverMachine()
        self.labelled = torch.zeros(1, dtype=torch.bool)
        x0, y0, x1, y1 = geometry.arena
        self._scale = self.window_px / max(x1 - x0, y1 - y0)  # px per cm
        self._cursor: tuple[float, float] | None = None  # cm
        self._offset = (0.0, 0.0)  # agent - cursor at the grab (cm)
        self._asked = False
        self.person_gates = False  # set once the loop asks this person when to take over (HG-DAgger)
        self._pygame: Any = None
        self._screen: Any = None
        self._clock: Any = None
        self._font: Any = None
        self._beep: Any = None

    # ---------------------------------------------------------------------------- device
    def connect(self) -> None:
        if self.is_connected:
            return
        try:
            import pygame  # noqa: PLC0415
        except ImportError as err:
            raise DeviceUnavailable(
                "expert=mouse needs pygame: `.venv/bin/pip install pygame==2.6.1` (make setup installs it)"
            ) from err
        pygame.display.init()
        try:
            self._screen = pygame.display.set_mode((self.window_px, self.window_px + BANNER_PX))
        except pygame.error as err:
            raise DeviceUnavailable(
                f"expert=mouse: no display to open a window on ({err}). Run on a desktop, with DISPLAY set, or under a "
                "virtual screen: `xvfb-run -s '-screen 0 1024x768x24' make teleop ...`"
            ) from err
        pygame.display.set_caption("dpiil_rl · aperture · you are the expert")
        pygame.font.init()
        self._font = pygame.font.SysFont(None, 24)
        self._clock = pygame.time.Clock()
        self._pygame = pygame
        if self.sound:
            self._beep = make_beep(pygame)
        super().connect()

    def disconnect(self) -> None:
        if self._pygame is not None:
            self._pygame.display.quit()
            self._pygame = None
        super().disconnect()

    # ---------------------------------------------------------------------------- coordinates
    def to_px(self, x: float, y: float) -> tuple[int, int]:
        x0, y0, _, _ = self.geometry.arena
        return int(round((x - x0) * self._scale)), int(round(self.window_px - (y - y0) * self._scale)) + BANNER_PX

    def to_cm(self, px: int, py: int) -> tuple[float, float]:
        x0, y0, _, _ = self.geometry.arena
        return px / self._scale + x0, (self.window_px + BANNER_PX - py) / self._scale + y0

    # ---------------------------------------------------------------------------- per step
    def observe(self, tensordict: TensorDictBase) -> None:
        """Every step: read the device, draw the scene, keep real time (robot or person driving)."""
        self._require()
        agent = tensordict.get(self.observation_key).reshape(-1, 2)[0]
        self._pump(agent)
        mode = tensordict.get("expert_mode", None)
        asking = bool(mode.reshape(-1)[0]) if mode is not None else False
        if asking and not self._asked and self._beep is not None:
            self._beep.play()
        self._asked = asking
        risk = tensordict.get("risk", None)
        self._draw(agent, asking, None if risk is None else float(risk.reshape(-1)[0]))
        if self.realtime:
            self._clock.tick(self.control_hz)

    def get_action(self, tensordict: TensorDictBase) -> torch.Tensor:
        self._require()
        agent = tensordict.get(self.observation_key).reshape(-1, 2)[0]
        self._pump(agent)
        action = torch.zeros(1, 2)
        if self.handover.moving and self._cursor is not None:
            target = (self._cursor[0] + self._offset[0], self._cursor[1] + self._offset[1])
            limit = float(self.geometry.max_speed)
            action[0, 0] = max(-limit, min(limit, target[0] - float(agent[0])))
            action[0, 1] = max(-limit, min(limit, target[1] - float(agent[1])))
        self.labelled = torch.tensor([self.handover.moving])
        return action.to(agent.device)

    def wants_control(self, tensordict: TensorDictBase, in_control: torch.Tensor) -> torch.Tensor:
        """HG-DAgger: the person takes over by pressing on the robot (and dragging it) and hands back by
        releasing the button; the robot drives whenever nobody holds it."""
        self._require()
        self.person_gates = True
        self._pump(tensordict.get(self.observation_key).reshape(-1, 2)[0])
        return torch.tensor([[self.handover.moving]])

    def reset(self, mask: torch.Tensor) -> None:
        if bool(mask.reshape(-1)[0]) and self.handover.state is not Handover.STOPPED:
            self.handover.fire(HandoverEvent.FOLLOW_END if self.handover.moving else HandoverEvent.DEVICE_LOST)

    # ---------------------------------------------------------------------------- internals
    def _require(self) -> None:
        if not self.is_connected:
            raise DeviceUnavailable(
                "expert=mouse is not connected: use it as a context manager or call connect() first"
            )

    def _pump(self, agent: torch.Tensor) -> None:
        pg = self._pygame
        for event in pg.event.get():
            if event.type == pg.QUIT:
                raise SessionEnded("the expert window was closed")
            if event.type in (pg.MOUSEMOTION, pg.MOUSEBUTTONDOWN, pg.MOUSEBUTTONUP):
                self._cursor = self.to_cm(*event.pos)
            if event.type == pg.MOUSEBUTTONDOWN and event.button == 1 and self._cursor is not None:
                dx, dy = float(agent[0]) - self._cursor[0], float(agent[1]) - self._cursor[1]
                if math.hypot(dx, dy) <= self.grab_radius + self.geometry.agent_radius:
                    self._offset = (dx, dy)
                    self.handover.fire(HandoverEvent.SYNC)
                    self.handover.fire(HandoverEvent.FOLLOW_START)
            elif event.type == pg.MOUSEBUTTONUP and event.button == 1:
                self.handover.fire(HandoverEvent.FOLLOW_END)
            elif event.type in (getattr(pg, "WINDOWFOCUSLOST", -1), getattr(pg, "WINDOWLEAVE", -1)):
                self.handover.fire(HandoverEvent.DEVICE_LOST)

    def _draw(self, agent: torch.Tensor, asking: bool, risk: float | None) -> None:
        pg, screen = self._pygame, self._screen
        screen.fill((250, 250, 250))
        for x0, y0, x1, y1 in self.geometry.rectangles().tolist():
            left, top = self.to_px(x0, y1)
            screen.fill(
                (110, 110, 110), pg.Rect(left, top, int((x1 - x0) * self._scale) + 1, int((y1 - y0) * self._scale) + 1)
            )
        gx0, gy0, gx1, gy1 = self.geometry.goal
        left, top = self.to_px(gx0, gy1)
        pg.draw.rect(
            screen, (40, 160, 60), pg.Rect(left, top, int((gx1 - gx0) * self._scale), int((gy1 - gy0) * self._scale)), 2
        )
        driving = self.handover.moving
        color = DRIVING_COLOUR if asking else AUTO_COLOUR
        pg.draw.circle(
            screen,
            color,
            self.to_px(float(agent[0]), float(agent[1])),
            max(3, int(self.geometry.agent_radius * self._scale)),
        )
        if self._cursor is not None:
            cx, cy = self.to_px(*self._cursor)
            pg.draw.line(screen, (0, 0, 0), (cx - 6, cy), (cx + 6, cy))
            pg.draw.line(screen, (0, 0, 0), (cx, cy - 6), (cx, cy + 6))
        lines = banner_lines(
            asking,
            asking and driving,
            self.handover.state.value,
            risk,
            "press on the robot and drag it",
            self.person_gates,
        )
        draw_banner(pg, screen, self._font, self.window_px, lines)
        pg.display.flip()
