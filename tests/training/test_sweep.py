"""`make paper` in small: a Hydra multirun over methods and seeds with the parallel launcher, a fixed-χ
sweep, a re-run that skips finished runs, and the study report over both."""

import json

from tests.conftest import run_script


def test_multirun_sweep_skips_finished_runs_and_feeds_the_report(tmp_path):
    common = [
        "experiment=smoke",
        "protocol.iterations=1",
        f"run_root={tmp_path}",
        "progress=false",
        "hydra/launcher=joblib",
        "hydra.launcher.n_jobs=2",
    ]
    run_script("train", "-m", "method=dagger,dpiil_ucb", "seed=0", "study=s", *common, timeout=600)
    run_script(
        "train",
        "-m",
        "method=dpiil_ucb",
        "chi=1e-3",
        "seed=0",
        "study=s_chi",
        "run_name=${method.name}-chi${chi}",
        *common,
        timeout=600,
    )
    summaries = sorted(tmp_path.glob("s/aperture/*/seed_*/summary.json"))
    assert [p.parent.parent.name for p in summaries] == ["dagger", "dpiil_ucb"]
    chi_runs = sorted(p.parent.parent.name for p in tmp_path.glob("s_chi/aperture/*/seed_0/summary.json"))
    assert chi_runs == ["dpiil_ucb-chi0.001"]
    assert (
        json.loads((tmp_path / "s_chi/aperture/dpiil_ucb-chi0.001/seed_0/summary.json").read_text())["chi_fixed"]
        == 1e-3
    )

    made = {p: p.read_text() for p in tmp_path.glob("s/aperture/*/seed_0/.hydra/*.yaml")}
    assert len(made) == 6
    # run again with one more key: the finished runs are skipped and their .hydra/ stays as they were made
    again = run_script(
        "train", "-m", "method=dagger,dpiil_ucb", "seed=0", "study=s", "checkpoint_keep=1", *common, timeout=600
    )
    assert again.stdout.count("is already finished") == 2  # nothing is trained twice
    assert {p: p.read_text() for p in made} == made
    assert "sweep: 100%" in again.stderr and "2/2" in again.stderr  # the sweep's progress bar
    assert not list((tmp_path / "s").glob(".sweep-progress-*"))  # its progress file is gone

    out = tmp_path / "report"
    run_script("report", f"runs=[{tmp_path / 's'},{tmp_path / 's_chi'}]", f"out={out}")
    for name in (
        "results.md",
        "results.csv",
        "stats.md",
        "fig3c_interactive.png",
        "fig3c_autonomous.png",
        "fig3a_maps.png",
        "fig3d_chi_sensitivity.png",
    ):
        assert (out / name).stat().st_size > 0, name
    assert "dagger" in (out / "results.md").read_text()
