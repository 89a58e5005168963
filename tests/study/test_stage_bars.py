"""The stage figure: one stacked bar per method, 100% each, drawn from stage counts."""

from collections import Counter

import pytest
from PIL import Image

from dpiil_rl.study.stage_bars import stage_bars, stage_colors
from dpiil_rl.study.stage_table import StageCounts

STAGES = ("reach", "grasped", "lifted", "threaded")


def test_draws_one_panel_per_kind(tmp_path):
    counts = [
        StageCounts("ring", "bc", 3, Counter(reach=2, threaded=8)),
        StageCounts("ring", "dpiil_ucb", 3, Counter(grasped=5, lifted=1, threaded=4)),
    ]
    path = stage_bars({"autonomous": counts, "interactive": counts[1:]}, STAGES, tmp_path / "stages.png", title="ring")
    width, height = Image.open(path).size
    assert width > 1.5 * height  # two panels side by side


def test_failure_stages_are_red_and_success_green():
    colors = stage_colors(len(STAGES))
    assert all(c[0] > c[1] for c in colors[:-1]) and colors[-1][1] > colors[-1][0]


def test_nothing_to_draw_is_named(tmp_path):
    with pytest.raises(ValueError, match="no episodes with stages"):
        stage_bars({"autonomous": [StageCounts("ring", "bc")]}, STAGES, tmp_path / "x.png")


def test_counts_that_are_not_episodes_are_coloured_in_order_and_labelled(tmp_path):
    colors = stage_colors(3, success_last=False)
    light = [sum(c[:3]) for c in colors]
    assert light == sorted(light, reverse=True) and all(c[2] >= c[0] for c in colors)  # one blue scale, darker = later
    pairs = [StageCounts("ring", "dpiil_ucb", 3, Counter(reach=47, grasped=49, lifted=2, at_peg=2))]
    path = stage_bars(
        {"expert pairs, k ≥ 1": pairs},
        ("reach", "grasped", "lifted", "at_peg"),
        tmp_path / "pairs.png",
        xlabel="% of the method's expert pairs",
        success_last=False,
    )
    assert Image.open(path).size[0] > 0
