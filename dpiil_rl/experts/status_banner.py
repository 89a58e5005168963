"""What a person sees at the top of every expert window: who drives, whether the robot asks for help.

Shared by the mouse window (aperture) and the simulation view of the pad / keyboard / SpaceMouse
sources (robosuite tasks), so both speak the same colours and words: blue = the robot drives, red =
the robot asks for help and nobody drives yet, orange = the person drives.
"""

from __future__ import annotations

import math
import os
from typing import Any

BANNER_PX = 60  # banner height (pixels)
AUTO_COLOUR = (40, 90, 200)
ASKING_COLOUR = (200, 30, 30)
DRIVING_COLOUR = (230, 120, 20)


def banner_lines(
    asking: bool, driving: bool, handover: str, risk: float | None, how_to_take_over: str, person_gates: bool = False
) -> tuple[tuple[int, int, int], str, str]:
    """Colour, headline and detail line for the banner.

    ``how_to_take_over`` completes "ROBOT ASKS FOR HELP - ..." with the device's gesture
    ("press on the robot and drag it", "press A, then hold B"). ``person_gates``: the person decides when
    to take over (HG-DAgger), so while the robot drives the banner says how to take it.
    """
    if asking and not driving:
        colour, text = ASKING_COLOUR, f"ROBOT ASKS FOR HELP - {how_to_take_over}"
    elif driving:
        colour, text = DRIVING_COLOUR, "EXPERT - you drive (release to stop)"
    elif person_gates:
        colour, text = AUTO_COLOUR, f"AUTO - take over any time: {how_to_take_over}"
    else:
        colour, text = AUTO_COLOUR, "AUTO - the robot drives"
    detail = f"hand-over: {handover}" + ("" if risk is None or math.isnan(risk) else f"   risk {risk:.3g}")
    return colour, text, detail


def draw_banner(pygame: Any, screen: Any, font: Any, width: int, lines: tuple[tuple[int, int, int], str, str]) -> None:
    """Fill the top :data:`BANNER_PX` rows of ``screen`` with the banner ``lines``."""
    colour, text, detail = lines
    screen.fill(colour, pygame.Rect(0, 0, width, BANNER_PX))
    screen.blit(font.render(text, True, (255, 255, 255)), (10, 8))
    screen.blit(font.render(detail, True, (255, 255, 255)), (10, 34))


def make_beep(pygame: Any) -> Any:
    """A short 880 Hz tone, or None where there is no audio device."""
    try:
        import numpy as np  # noqa: PLC0415

        if os.environ.get("SDL_AUDIODRIVER") == "dummy":
            return None
        pygame.mixer.init(frequency=22_050, size=-16, channels=1)
        t = np.arange(int(0.15 * 22_050)) / 22_050
        wave = (0.3 * 32767 * np.sin(2 * np.pi * 880 * t)).astype(np.int16)
        return pygame.sndarray.make_sound(wave)
    except Exception:  # no sound card: the banner and the text still say it
        return None
