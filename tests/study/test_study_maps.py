"""Fig. 3(a) of a study from a real tiny run: maps from its initial checkpoint, one trajectory per method."""

import json
import shutil

import pytest

from dpiil_rl.study.study_maps import first_interactive_episode, plot_study_maps
from dpiil_rl.study.study_report import write_study_report
from dpiil_rl.study.study_runs import load_study
from tests.conftest import run_script, smoke_overrides
from tests.study.test_study_report import assert_real_png


@pytest.fixture(scope="module")
def tiny_study(tmp_path_factory):
    """One smoke run of dpiil_ucb, and a copy of it labelled ensemble_dagger (same seed, same episodes)."""
    root = tmp_path_factory.mktemp("study")
    run_dir = root / "aperture" / "dpiil_ucb" / "seed_0"
    run_script(
        "train",
        *smoke_overrides(
            run_dir,
            "logger=none",
            "protocol.iterations=1",
            "protocol.eval_episodes=10",
            "protocol.eval_envs=10",
            "modules.actor.fit.steps=60",
            "modules.actor.fit.epochs=null",
            "modules.speed_head.fit.steps=60",
        ),
    )
    copy = root / "aperture" / "ensemble_dagger" / "seed_0"
    shutil.copytree(run_dir, copy, ignore=shutil.ignore_patterns("buffer", "checkpoints"))
    summary = json.loads((copy / "summary.json").read_text())
    (copy / "summary.json").write_text(json.dumps({**summary, "method": "ensemble_dagger"}))
    return root


def test_the_report_of_a_real_run_draws_maps_and_trajectories(tiny_study, tmp_path):
    result = write_study_report(tiny_study, tmp_path / "report")
    assert result["runs"] == 2
    for name in ("fig3c_interactive.png", "fig3c_autonomous.png"):
        assert_real_png(tmp_path / "report" / name)
    assert_real_png(tmp_path / "report" / "fig3a_maps.png", min_bytes=40_000, min_colours=200)
    note = next(n for n in result["notes"] if "fig3a" in n)
    assert "seed 0" in note and "dpiil_ucb's iter_000" in note
    assert "for dagger" in note  # only dagger has no run; ensemble_dagger's trajectory is drawn
    found = first_interactive_episode(next(r for r in load_study(tiny_study) if r.method == "ensemble_dagger"))
    assert found is not None
    row, success = found
    assert row["iteration"] == 1 and row["phase"] == "interactive" and isinstance(success, bool)


def test_maps_without_a_checkpoint_or_seed_are_skipped_with_a_note(tiny_study, tmp_path):
    runs = load_study(tiny_study)
    others = [r for r in runs if r.method != "dpiil_ucb"]  # the copy has no checkpoints
    path, note = plot_study_maps(others, tmp_path / "none.png")
    assert path is None and "skipped" in note and not (tmp_path / "none.png").exists()
    path, note = plot_study_maps(runs, tmp_path / "seed5.png", seed=5)
    assert path is None and "seed 5" in note
