"""``expert=gamepad``: a person drives a robosuite task's end effector with a game pad (Xbox layout).

Buttons follow the paper's Fig. 5(c): **A** syncs (the pad takes over from a standstill), **B** held
makes the robot follow the sticks, releasing B stops it (press A again before moving), **Y** held lets
the learned policy run; with ``method=hg_dagger`` A then B held is the person taking over, releasing
B hands back. Sticks command the 6-D action ``[dx, dy, dz, rot_y, rot_z, gripper]``:
left stick = x/y, right stick vertical = z, right stick horizontal = rotation about z, the bumpers
(LB/RB) = rotation about y, **X** toggles the gripper. Commands are scaled by ``speed`` and pass a
dead zone, so a pad at rest commands nothing.

The pad is read through a small device layer (:class:`PadReader`): :class:`PygameJoystickReader`
for a real pad (pygame's joystick API), or any other reader named in the config (the tests drive the
protocol with a scripted button sequence). A pad that is absent or unplugged stops the robot (zero
action, shown as ``device lost``) and the run goes on; the message says which device and what to do.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Any, Protocol

import torch
from tensordict import TensorDictBase
from torchrl.envs import EnvBase

from dpiil_rl.experts.base import ExpertSource, check_person_env
from dpiil_rl.experts.handover import Handover, HandoverEvent, HandoverMachine
from dpiil_rl.experts.sim_view import SimView, display_available
from dpiil_rl.utils.config import build_component
from dpiil_rl.utils.pacing import RealTimePacer

log = logging.getLogger(__name__)

# Xbox layout as SDL reports it
BUTTON_A, BUTTON_B, BUTTON_X, BUTTON_Y, BUTTON_LB, BUTTON_RB = 0, 1, 2, 3, 4, 5
AXIS_LX, AXIS_LY, AXIS_RX, AXIS_RY = 0, 1, 3, 4


@dataclass
class PadState:
    """One reading of the pad: ``axes`` in [-1, 1], ``buttons`` pressed; ``connected`` False when lost."""

    axes: list[float] = field(default_factory=lambda: [0.0] * 6)
    buttons: list[bool] = field(default_factory=lambda: [False] * 11)
    connected: bool = True


class PadReader(Protocol):
    name: str

    def open(self) -> None: ...

    def read(self) -> PadState: ...

    def close(self) -> None: ...


class PygameJoystickReader:
    """The first (or ``index``-th) game pad through pygame's joystick API."""

    HELP = (
        "A: sync   B (hold): follow   Y (hold): policy   X: gripper",
        "left stick: x/y   right stick: z, turn z   LB/RB: turn y",
    )

    def __init__(self, index: int = 0) -> None:
        self.index = int(index)
        self.name = f"game pad #{self.index}"
        self._pygame: Any = None
        self._pad: Any = None

    def open(self) -> None:
        import pygame  # noqa: PLC0415

        pygame.init()
        pygame.joystick.init()
        self._pygame = pygame
        self._attach()

    def _attach(self) -> bool:
        pg = self._pygame
        if pg.joystick.get_count() <= self.index:
            self._pad = None
            return False
        self._pad = pg.joystick.Joystick(self.index)
        self._pad.init()
        self.name = f"game pad #{self.index} ({self._pad.get_name()})"
        return True

    def read(self) -> PadState:
        pg = self._pygame
        for event in pg.event.get((pg.JOYDEVICEADDED, pg.JOYDEVICEREMOVED)):
            if event.type == pg.JOYDEVICEREMOVED:
                self._pad = None
            elif event.type == pg.JOYDEVICEADDED and self._pad is None:
                self._attach()
        pg.event.pump()
        if self._pad is None:
            return PadState(connected=False)
        return PadState(
            axes=[self._pad.get_axis(i) for i in range(self._pad.get_numaxes())],
            buttons=[bool(self._pad.get_button(i)) for i in range(self._pad.get_numbuttons())],
        )

    def close(self) -> None:
        if self._pygame is not None:
            self._pygame.joystick.quit()


class DeviceTeleopExpert(ExpertSource):
    labels_every_step = False  # a person's input means something only while they drive

    def __init__(
        self,
        env: EnvBase,
        seed: int = 0,
        reader: Any = None,
        speed: float = 0.6,
        rotation_speed: float = 0.4,
        dead_zone: float = 0.12,
        control_hz: float = 20.0,
        realtime: bool = True,
        view: bool | None = None,
        view_camera: str = "frontview",
        view_size: tuple[int, int] = (480, 360),
        view_every: int = 2,
        sound: bool = True,
    ) -> None:
        super().__init__()
        del seed
        check_person_env(env, "gamepad", 6, "the 6-D end-effector action of a robosuite task (env=ring)")
        if not 0 < speed <= 1 or not 0 < rotation_speed <= 1 or not 0 <= dead_zone < 1:
            raise ValueError(
                f"expert.speed = {speed}, rotation_speed = {rotation_speed}, dead_zone = {dead_zone}: "
                "expected speeds in (0, 1] and a dead zone in [0, 1)"
            )
        if not control_hz > 0:
            raise ValueError(f"expert.control_hz = {control_hz}: expected a positive control rate (Hz)")
        self.reader: PadReader = build_component(
            reader, f"{PygameJoystickReader.__module__}.{PygameJoystickReader.__name__}"
        )
        self.speed, self.rotation_speed, self.dead_zone = float(speed), float(rotation_speed), float(dead_zone)
        self.pacer = RealTimePacer(1.0 / float(control_hz))
        self.realtime = bool(realtime)
        self.handover = HandoverMachine()
        self.labelled = torch.zeros(1, dtype=torch.bool)
        self.gripper = -1.0  # open
        self._previous = PadState()
        self._lost_reported = False
        self.person_gates = False  # set once the loop asks this person when to take over (HG-DAgger)
        # the on-screen view: where a display exists (view: null) or when asked (true); needs env.render_frame
        self.view: SimView | None = None
        render = getattr(env, "render_frame", None)
        wanted = display_available() if view is None else bool(view)
        if wanted and render is None:
            log.warning("env %s cannot render: no on-screen view", type(env).__name__)
        elif wanted and render is not None:
            width, height = (int(v) for v in view_size)
            self.view = SimView(
                lambda: render(0, width, height, view_camera),
                width,
                height,
                int(view_every),
                help_lines=getattr(self.reader, "HELP", ()),
                sound=sound,
                title=f"dpiil_rl · {self.reader.name} · you are the expert",
                how_to_take_over=getattr(self.reader, "TAKE_OVER", "press A, then hold B"),
            )

    def connect(self) -> None:
        if self.is_connected:
            return
        if self.view is not None and not self.view.open():  # first: a key reader then takes keys from this window
            self.view = None
        self.reader.open()
        super().connect()

    def disconnect(self) -> None:
        if self.is_connected:
            self.reader.close()
            if self.view is not None:
                self.view.close()
        super().disconnect()

    @property
    def policy_requested(self) -> bool:
        """Y held: the person lets the learned policy run."""
        return self.handover.state.value == "policy"

    def observe(self, tensordict: TensorDictBase) -> None:
        """Every step: read the device, redraw the view, keep real time (whoever drives)."""
        self._update(self.reader.read())
        if self.view is not None:
            mode = tensordict.get("expert_mode", None)
            asking = bool(mode.reshape(-1)[0]) if mode is not None else False
            risk = tensordict.get("risk", None)
            self.view.show(
                asking,
                asking and self.handover.moving,
                self.handover.state.value,
                None if risk is None else float(risk.reshape(-1)[0]),
                self.person_gates,
            )
        if self.realtime:
            self.pacer.wait()

    def get_action(self, tensordict: TensorDictBase) -> torch.Tensor:
        pad = self.reader.read()
        self._update(pad)
        action = torch.zeros(1, 6)
        if self.handover.moving and pad.connected:
            axes = pad.axes + [0.0] * (6 - len(pad.axes))
            lx, ly, rx, ry = (self._dz(axes[i]) for i in (AXIS_LX, AXIS_LY, AXIS_RX, AXIS_RY))
            bumpers = float(_pressed(pad, BUTTON_RB)) - float(_pressed(pad, BUTTON_LB))
            action[0, :3] = torch.tensor([-ly, -lx, -ry]) * self.speed  # stick up = away from the person (+x)
            action[0, 3] = bumpers * self.rotation_speed
            action[0, 4] = -rx * self.rotation_speed
        action[0, 5] = self.gripper
        self.labelled = torch.tensor([self.handover.moving and pad.connected])
        return action

    def wants_control(self, tensordict: TensorDictBase, in_control: torch.Tensor) -> torch.Tensor:
        """HG-DAgger: the person takes over by following (A, then B held) and hands back by releasing B."""
        del tensordict, in_control
        self.person_gates = True
        self._update(self.reader.read())
        return torch.tensor([[self.handover.moving]])

    def reset(self, mask: torch.Tensor) -> None:
        """A new episode: the robot starts elsewhere, so the person syncs again before moving it."""
        if bool(mask.reshape(-1)[0]) and self.handover.state is not Handover.STOPPED:
            self.handover.fire(HandoverEvent.FOLLOW_END if self.handover.moving else HandoverEvent.DEVICE_LOST)

    # ---------------------------------------------------------------------------- internals
    def _dz(self, value: float) -> float:
        return (
            0.0
            if abs(value) < self.dead_zone
            else (value - self.dead_zone * (1 if value > 0 else -1)) / (1 - self.dead_zone)
        )

    def _update(self, pad: PadState) -> None:
        prev = self._previous
        if not pad.connected:
            if not self._lost_reported:
                log.warning(
                    "%s lost: the robot stops. Plug it back in (it is picked up again), then press A to sync.",
                    self.reader.name,
                )
                self._lost_reported = True
            self.handover.fire(HandoverEvent.DEVICE_LOST)
            self._previous = PadState(connected=False)
            return
        self._lost_reported = False
        for event in button_events(prev, pad):
            self.handover.fire(event)
        if _pressed(pad, BUTTON_X) and not _pressed(prev, BUTTON_X):
            self.gripper = -self.gripper
        self._previous = pad


def button_events(previous: PadState, pad: PadState) -> list[HandoverEvent]:
    """The hand-over events of the pad's button edges since ``previous`` (Fig. 5(c)): A pressed = sync,
    B pressed / released = follow start / end, Y pressed / released = policy start / end."""
    edges = (
        (BUTTON_A, HandoverEvent.SYNC, None),
        (BUTTON_B, HandoverEvent.FOLLOW_START, HandoverEvent.FOLLOW_END),
        (BUTTON_Y, HandoverEvent.POLICY_START, HandoverEvent.POLICY_END),
    )
    events = []
    for button, on_press, on_release in edges:
        now, before = _pressed(pad, button), _pressed(previous, button)
        if now and not before:
            events.append(on_press)
        elif before and not now and on_release is not None:
            events.append(on_release)
    return events


def _pressed(pad: PadState, button: int) -> bool:
    return pad.connected and button < len(pad.buttons) and bool(pad.buttons[button])
