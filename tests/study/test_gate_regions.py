"""Expert share near / far from a point and the contact episodes' numbers, on a hand-made run."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from dpiil_rl.study.gate_regions import gate_regions, regions_table
from dpiil_rl.study.study_runs import load_study
from tests.study.synthetic_runs import write_run

ROOT = Path(__file__).resolve().parents[2]
POINT, OFFSET, RADIUS = [0.0, 0.0, 0.0], [0.1, 0.0, 0.0], 0.03


def _run_with_3d_paths(tmp_path: Path) -> Path:
    """One dpiil_ucb run with two interactive episodes (a success, then a contact), χ = 1e-3."""
    run_dir = write_run(tmp_path, "dpiil_ucb", 0, [0.5], [0.5, 0.5], n_interactive=2, expert_steps=0)
    episodes = [json.loads(line) for line in (run_dir / "episodes.jsonl").read_text().splitlines()]
    success, contact = [e for e in episodes if e["phase"] == "interactive"]
    assert success["success"] and contact["collision"]
    rows = [  # positions are the TCP's; the point that matters is 10 cm in front of it (OFFSET)
        {
            "episode": success["episode"],
            "phase": "interactive",
            "iteration": 1,
            "positions": [[-0.2, 0, 0.1], [-0.15, 0, 0.05], [-0.1, 0, 0.01], [-0.1, 0, 0.0]],
            "expert_mode": [True, True, False],
            "risk": [2e-3, 2e-3, 1e-4],
        },
        {
            "episode": contact["episode"],
            "phase": "interactive",
            "iteration": 1,
            "positions": [[-0.2, 0, 0.1], [-0.1, 0.004, 0.02], [-0.1, 0.005, 0.01]],
            "expert_mode": [False, False],
            "risk": [1e-4, 5e-4],
        },
    ]
    (run_dir / "paths.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    return run_dir


def test_counts_expert_steps_near_and_far_and_the_contact(tmp_path: Path) -> None:
    _run_with_3d_paths(tmp_path)
    [stats] = gate_regions(load_study(tmp_path), POINT, OFFSET, RADIUS)
    assert (stats.method, stats.runs, stats.interactive_episodes, stats.contact_episodes) == ("dpiil_ucb", 1, 2, 1)
    assert (stats.near_steps, stats.near_expert, stats.far_steps, stats.far_expert) == (2, 0, 3, 2)
    assert stats.far_share == pytest.approx(2 / 3) and stats.near_share == 0.0
    assert stats.contact_requests == [0]
    assert stats.contact_axis_mm == [pytest.approx(5.0)]
    assert stats.contact_height == [pytest.approx(0.01)]
    assert stats.contact_risk_over_chi == [pytest.approx(0.5)]  # risk 5e-4 at the last step, χ of iteration 0 = 1e-3
    table = regions_table([stats], RADIUS)
    assert (
        "| dpiil_ucb | 1 | 0.00 (2 steps) | 0.67 (3 steps) | 1 of 2 | 1 | 5.0 (5.0–5.0) | 0.010–0.010 | 0.50, 0.50 |"
        in table
    )


def test_methods_without_interactive_episodes_are_left_out(tmp_path: Path) -> None:
    _run_with_3d_paths(tmp_path)
    write_run(tmp_path, "bc", 0, None, [0.5, 0.5])
    assert [s.method for s in gate_regions(load_study(tmp_path), POINT, OFFSET, RADIUS)] == ["dpiil_ucb"]


@pytest.mark.parametrize(
    ("point", "radius", "match"),
    [
        ([0.0, 0.0], RADIUS, r"point = \[0.0, 0.0\]: expected three finite numbers"),
        ([0.0, float("nan"), 0.0], RADIUS, "point = .*expected three finite numbers"),
        (POINT, 0.0, r"radius = 0.0: expected a positive distance"),
    ],
)
def test_bad_point_or_radius_is_named(tmp_path: Path, point: list[float], radius: float, match: str) -> None:
    _run_with_3d_paths(tmp_path)
    with pytest.raises(ValueError, match=match):
        gate_regions(load_study(tmp_path), point, OFFSET, radius)


def test_planar_paths_are_refused(tmp_path: Path) -> None:
    write_run(tmp_path, "dpiil_ucb", 0, [0.5], [0.5, 0.5])  # the aperture task's 2-D positions
    with pytest.raises(ValueError, match="2-D positions; expected 3-D"):
        gate_regions(load_study(tmp_path), POINT, OFFSET, RADIUS)


def test_command_prints_the_table(tmp_path: Path) -> None:
    _run_with_3d_paths(tmp_path)
    cmd = [sys.executable, "-m", "dpiil_rl.cli.gate_regions", f"runs={tmp_path}", "point=[0,0,0]", "offset=[0.1,0,0]"]
    out = subprocess.run(cmd, capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert out.returncode == 0, out.stderr
    assert "| dpiil_ucb | 1 | 0.00 (2 steps) |" in out.stdout
    missing = subprocess.run(cmd[:4], capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert missing.returncode == 2 and "point: not given" in missing.stderr
