"""The stage figure: one stacked bar per method, 100% each, drawn from stage counts."""

from collections import Counter

import pytest
from PIL import Image

from dpiil_rl.plots.stage_bars import stage_bars, stage_colors
from dpiil_rl.records.stage_table import StageCounts

STAGES = ("reach", "grasped", "lifted", "threaded")


def test_draws_one_panel_per_kind(tmp_path):
    counts = [StageCounts("ring", "bc", 3, Counter(reach=2, threaded=8)),
              StageCounts("ring", "dpiil_ucb", 3, Counter(grasped=5, lifted=1, threaded=4))]
    path = stage_bars({"autonomous": counts, "interactive": counts[1:]}, STAGES, tmp_path / "stages.png", title="ring")
    width, height = Image.open(path).size
    assert width > 1.5 * height  # two panels side by side


def test_failure_stages_are_red_and_success_green():
    colors = stage_colors(len(STAGES))
    assert all(c[0] > c[1] for c in colors[:-1]) and colors[-1][1] > colors[-1][0]


def test_nothing_to_draw_is_named(tmp_path):
    with pytest.raises(ValueError, match="no episodes with stages"):
        stage_bars({"autonomous": [StageCounts("ring", "bc")]}, STAGES, tmp_path / "x.png")
