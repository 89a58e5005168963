"""Device readers for :class:`~dpiil_rl.experts.device_teleop.DeviceTeleopExpert`: keyboard and SpaceMouse.

Each reader turns its device into a :class:`~dpiil_rl.experts.device_teleop.PadState` in the Xbox
layout, so every device speaks the same hand-over protocol (A sync, B held follow, Y held policy,
X gripper) and the same 6-D command mapping.

- :class:`PygameKeyboardReader` (``expert=keyboard``): a small pygame window takes the keys. W/S and
  A/D move in x and y, R/F in z, Q/E turn about z, Z/C about y; Enter = A (sync), Space held = B
  (follow), P held = Y (policy), G = X (gripper). Closing the window counts as a lost device.
- :class:`SpaceMouseReader` (``expert=spacemouse``): a 3Dconnexion SpaceMouse read through ``hid``
  (hidapi), 6-DoF to the sticks' axes; its left button syncs and follows while held, the right one
  toggles the gripper. Without ``hid`` or without a SpaceMouse it reports a lost device and says how
  to fix it.
"""

from __future__ import annotations

import logging
from typing import Any

from dpiil_rl.experts.device_teleop import (
    AXIS_LX,
    AXIS_LY,
    AXIS_RX,
    AXIS_RY,
    BUTTON_A,
    BUTTON_B,
    BUTTON_LB,
    BUTTON_RB,
    BUTTON_X,
    BUTTON_Y,
    PadState,
)

log = logging.getLogger(__name__)


class PygameKeyboardReader:
    """Keys of a focused pygame window as a pad."""

    HELP = (
        "Enter: sync   Space (hold): follow   P (hold): policy   G: gripper",
        "W/S: x   A/D: y   R/F: z   Q/E: turn z   Z/C: turn y",
    )
    TAKE_OVER = "press Enter, then hold Space"

    def __init__(self, window_px: int = 520) -> None:
        self.name = "keyboard window"
        self.window_px = int(window_px)
        self._pygame: Any = None
        self._screen: Any = None
        self._font: Any = None
        self._open = False
        self._held: set[int] = set()

    def open(self) -> None:
        import pygame  # noqa: PLC0415

        pygame.display.init()
        pygame.font.init()
        self._pygame = pygame
        if pygame.display.get_surface() is not None:
            # a window is open already (the simulation view): take the keys there; it draws the help and
            # handles its own closing
            self._screen = None
            self._open = True
            return
        try:
            self._screen = pygame.display.set_mode((self.window_px, 90))
        except pygame.error as err:
            log.warning(
                "keyboard: no display for the key window (%s); the robot stays still. Run on a desktop or "
                "under xvfb-run.",
                err,
            )
            return
        pygame.display.set_caption("dpiil_rl · keyboard expert")
        self._font = pygame.font.SysFont(None, 22)
        self._open = True

    def read(self) -> PadState:
        pg = self._pygame
        if not self._open:
            return PadState(connected=False)
        own_window = self._screen is not None
        kinds = (pg.KEYDOWN, pg.KEYUP, getattr(pg, "WINDOWFOCUSLOST", pg.NOEVENT)) + ((pg.QUIT,) if own_window else ())
        tapped: set[int] = set()
        for event in pg.event.get(kinds):
            if event.type == pg.QUIT:
                self._open = False
                return PadState(connected=False)
            if event.type == pg.KEYDOWN:
                self._held.add(event.key)
                tapped.add(event.key)
            elif event.type == pg.KEYUP:
                self._held.discard(event.key)
            else:  # focus lost: no key is held any more
                self._held.clear()
        # a key pressed and released between two reads (a quick tap on Enter while a step renders) still
        # counts as pressed for this read, or the tap would be lost
        held = self._held | tapped

        def key(k: int) -> float:
            return float(k in held)

        state = PadState()
        state.axes[AXIS_LY] = key(pg.K_s) - key(pg.K_w)  # W: +x (stick forward)
        state.axes[AXIS_LX] = key(pg.K_d) - key(pg.K_a)  # A: +y
        state.axes[AXIS_RY] = key(pg.K_f) - key(pg.K_r)  # R: +z
        state.axes[AXIS_RX] = key(pg.K_e) - key(pg.K_q)  # Q: +rotation about z
        state.buttons[BUTTON_A] = pg.K_RETURN in held
        state.buttons[BUTTON_B] = pg.K_SPACE in held
        state.buttons[BUTTON_Y] = pg.K_p in held
        state.buttons[BUTTON_X] = pg.K_g in held
        state.buttons[BUTTON_LB] = pg.K_z in held
        state.buttons[BUTTON_RB] = pg.K_c in held
        if own_window:
            self._draw()
        return state

    def _draw(self) -> None:
        self._screen.fill((40, 90, 200))
        for i, line in enumerate(self.HELP):
            self._screen.blit(self._font.render(line, True, (255, 255, 255)), (10, 12 + 30 * i))
        self._pygame.display.flip()

    def close(self) -> None:
        if self._pygame is not None:
            self._pygame.display.quit()
        self._open = False


class SpaceMouseReader:
    """A 3Dconnexion SpaceMouse through hidapi (HID reports: 1 translation, 2 rotation, 3 buttons)."""

    VENDOR_ID = 0x256F  # 3Dconnexion
    SCALE = 350.0  # raw counts at full deflection
    HELP = (
        "left button (hold): sync and follow   right button: gripper",
        "push / pull / lift the cap: x, y, z   tilt / twist: turn y, z",
    )
    TAKE_OVER = "press and hold the left button"

    def __init__(self, vendor_id: int = VENDOR_ID, product_id: int | None = None) -> None:
        self.vendor_id, self.product_id = int(vendor_id), product_id
        self.name = "SpaceMouse"
        self._device: Any = None
        self._axes = [0.0] * 6
        self._left = self._right = False

    def open(self) -> None:
        try:
            # hidapi is optional (a SpaceMouse's driver, installed by hand): absent from the pinned environment
            import hid  # noqa: PLC0415  # pyright: ignore[reportMissingImports]
        except ImportError:
            log.warning(
                "SpaceMouse: the `hid` package is missing: `.venv/bin/pip install hidapi`; the robot stays still."
            )
            return
        found = [
            d
            for d in hid.enumerate()
            if d.get("vendor_id") == self.vendor_id
            and (self.product_id is None or d.get("product_id") == self.product_id)
        ]
        if not found:
            log.warning(
                "SpaceMouse: no 3Dconnexion device found (vendor %#06x); plug it in and check its udev permissions.",
                self.vendor_id,
            )
            return
        self._device = hid.device()
        self._device.open(found[0]["vendor_id"], found[0]["product_id"])
        self._device.set_nonblocking(True)
        self.name = f"SpaceMouse ({found[0].get('product_string', 'unknown')})"

    def read(self) -> PadState:
        if self._device is None:
            return PadState(connected=False)
        try:
            while True:
                report = self._device.read(13)
                if not report:
                    break
                self._apply(report)
        except OSError:
            self._device = None
            return PadState(connected=False)
        state = PadState()
        x, y, z, roll, pitch, yaw = self._axes
        state.axes[AXIS_LY], state.axes[AXIS_LX], state.axes[AXIS_RY], state.axes[AXIS_RX] = -x, -y, -z, -yaw
        state.buttons[BUTTON_A] = state.buttons[BUTTON_B] = self._left  # press = sync, held = follow
        state.buttons[BUTTON_X] = self._right
        state.buttons[BUTTON_RB], state.buttons[BUTTON_LB] = pitch > 0.5, pitch < -0.5
        return state

    def _apply(self, report: list[int]) -> None:
        def axis(lo: int, hi: int) -> float:
            value = report[lo] | (report[hi] << 8)
            value = value - 65536 if value >= 32768 else value
            return max(-1.0, min(1.0, value / self.SCALE))

        if report[0] == 1 and len(report) >= 7:
            self._axes[0:3] = [axis(1, 2), axis(3, 4), axis(5, 6)]
            if len(report) >= 13:  # newer devices send rotation in the same report
                self._axes[3:6] = [axis(7, 8), axis(9, 10), axis(11, 12)]
        elif report[0] == 2 and len(report) >= 7:
            self._axes[3:6] = [axis(1, 2), axis(3, 4), axis(5, 6)]
        elif report[0] == 3 and len(report) >= 2:
            self._left, self._right = bool(report[1] & 1), bool(report[1] & 2)

    def close(self) -> None:
        if self._device is not None:
            self._device.close()
            self._device = None
