"""Study figures drawn from plain numbers: every input shape the report can produce gives a real PNG."""

import math

import numpy as np
import pytest

from dpiil_rl.study.study_figures import (
    autonomous_vs_expert_actions,
    chi_sensitivity,
    interactive_boxplot,
    mean_curve,
    method_color,
)
from dpiil_rl.study.study_runs import METHOD_ORDER
from dpiil_rl.study.study_stats import ChiFit, ChiPoint, MeanStd
from tests.study.test_study_report import assert_real_png


def test_interactive_boxplot_skips_methods_without_interactive_runs(tmp_path):
    values = {"dpiil_ucb": [0.9, 1.0, 0.95], "bc": [], "dagger": [0.5, 0.6, 0.4], "new": [0.7]}
    path = interactive_boxplot(
        values,
        {"dagger": 1e-4, "new": math.nan},
        "dpiil_ucb",
        tmp_path / "box.png",
        paper={"dagger": 52.0, "dpiil_ucb": 96.0, "bc": None},
        title="aperture",
    )
    assert_real_png(path)


def test_interactive_boxplot_with_nothing_to_show(tmp_path):
    assert_real_png(
        interactive_boxplot({"bc": []}, {}, "dpiil_ucb", tmp_path / "empty.png"), min_bytes=3_000, min_colours=2
    )


def test_mean_curve_averages_seeds_per_iteration():
    curves = [
        [
            {"iteration": 0, "expert_actions": 100, "autonomous_success": 0.2},
            {"iteration": 1, "expert_actions": 300, "autonomous_success": 0.6},
        ],
        [
            {"iteration": 0, "expert_actions": 110, "autonomous_success": 0.4},
            {"iteration": 1, "expert_actions": 310, "autonomous_success": 1.0},
            {"iteration": 2, "expert_actions": 500, "autonomous_success": 1.0},
        ],
    ]
    c = mean_curve(curves)
    assert c["iteration"].tolist() == [0, 1, 2]
    assert c["x"].tolist() == pytest.approx([105, 305, 500])
    assert c["mean"].tolist() == pytest.approx([0.3, 0.8, 1.0])
    assert c["std"].tolist() == pytest.approx([np.std([0.2, 0.4], ddof=1), np.std([0.6, 1.0], ddof=1), 0.0])
    assert c["n"].tolist() == [2, 2, 1]


def test_autonomous_curves(tmp_path):
    rng = np.random.default_rng(1)
    curves = {
        m: [
            [
                {"iteration": k, "expert_actions": 250 + 200 * k, "autonomous_success": float(rng.uniform())}
                for k in range(6)
            ]
            for _ in range(3)
        ]
        for m in ("dpiil_ucb", "dagger", "some_new_method")
    }
    assert_real_png(autonomous_vs_expert_actions(curves, tmp_path / "auto.png", paper={"dagger": 79.0}))


def test_chi_sensitivity(tmp_path):
    points = [
        ChiPoint(
            "aperture",
            m,
            chi,
            [0, 1],
            {"interactive_success": MeanStd(0.9 - 0.1 * i, 0.05, 2), "autonomous_success": MeanStd(0.8, math.nan, 1)},
        )
        for m in ("dpiil_ucb", "ensemble_dagger")
        for i, chi in enumerate((1e-5, 1e-4, 1e-3))
    ]
    fits = [
        ChiFit("aperture", "dpiil_ucb", "interactive_success", 6, -0.9, 0.81, 0.01),
        ChiFit("aperture", "ensemble_dagger", "autonomous_success", 6, math.nan, math.nan, math.nan, "constant input"),
    ]
    assert_real_png(chi_sensitivity(points, fits, tmp_path / "chi.png"))


def test_every_known_method_has_a_colour_of_its_own():
    # the extra baselines once hashed onto the colours of paper methods (safe_dagger drew like dpiil_mu)
    colours = [method_color(m) for m in METHOD_ORDER]
    assert len(set(colours)) == len(colours)
    assert method_color("my_baseline") == method_color("my_baseline")  # an unknown method: stable
