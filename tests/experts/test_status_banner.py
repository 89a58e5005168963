"""The banner's words: who drives, whether the robot asks, and (HG-DAgger) how to take over any time."""

import math

from dpiil_rl.experts.status_banner import ASKING_COLOUR, AUTO_COLOUR, DRIVING_COLOUR, banner_lines

HOW = "press A, then hold B"


def test_asking_driving_and_auto():
    assert banner_lines(True, False, "stopped", 0.5, HOW)[:2] == (ASKING_COLOUR, f"ROBOT ASKS FOR HELP - {HOW}")
    assert banner_lines(True, True, "following", None, HOW)[:2] == (
        DRIVING_COLOUR,
        "EXPERT - you drive (release to stop)",
    )
    assert banner_lines(False, False, "stopped", math.nan, HOW) == (
        AUTO_COLOUR,
        "AUTO - the robot drives",
        "hand-over: stopped",
    )


def test_a_person_who_gates_is_told_how_to_take_over_while_the_robot_drives():
    colour, text, detail = banner_lines(False, False, "synced", 0.0123, HOW, person_gates=True)
    assert (
        colour == AUTO_COLOUR
        and text == f"AUTO - take over any time: {HOW}"
        and detail == "hand-over: synced   risk 0.0123"
    )
