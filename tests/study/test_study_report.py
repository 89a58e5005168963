"""The study report: files, table numbers beside the paper's, stats, figures, and the entry script."""

import csv
import json
from pathlib import Path

import numpy as np
import pytest
from matplotlib.image import imread

from dpiil_rl.study.intervals import bootstrap_ci
from dpiil_rl.study.study_report import load_paper_reference, summary_text, write_study_report
from dpiil_rl.study.study_runs import load_study
from tests.conftest import ROOT, run_script
from tests.study.synthetic_runs import write_chi_study, write_run, write_study


def assert_real_png(path, min_bytes=8_000, min_colours=8):
    """A PNG with content: not tiny and not a blank canvas."""
    assert path.exists(), path
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert path.stat().st_size > min_bytes, (path, path.stat().st_size)
    image = imread(path)
    assert len(np.unique(image.reshape(-1, image.shape[-1]), axis=0)) >= min_colours


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    tmp_path = tmp_path_factory.mktemp("study")
    write_study(tmp_path / "main")
    write_chi_study(tmp_path / "chi")
    out = tmp_path / "report"
    return write_study_report([tmp_path / "main", tmp_path / "chi"], out), out, tmp_path


def test_writes_every_file(report):
    result, out, _ = report
    for name in ("results.md", "results.csv", "stats.md", "stats.json"):
        assert (out / name).stat().st_size > 100, name
    for name in ("fig3c_interactive.png", "fig3c_autonomous.png", "fig3d_chi_sensitivity.png"):
        assert_real_png(out / name)
    # synthetic runs have no checkpoints: the map is skipped with a note, not an error
    assert not (out / "fig3a_maps.png").exists()
    assert any("fig3a skipped" in n for n in result["notes"])
    assert result["runs"] == 23 and result["sensitivity_runs"] == 12


def test_results_table_is_recomputed_and_beside_the_paper(report):
    _, out, tmp_path = report
    rows = {r["method"]: r for r in csv.DictReader((out / "results.csv").open())}
    assert list(rows) == ["bc", "dagger", "dpiil_ucb", "my_new_method"]
    runs = [r for r in load_study(tmp_path / "main") if r.method == "dagger"]
    inter = [r.summary["interactive_success"] for r in runs]
    assert float(rows["dagger"]["interactive_success_mean"]) == pytest.approx(np.mean(inter))
    assert float(rows["dagger"]["interactive_success_std"]) == pytest.approx(np.std(inter, ddof=1))
    assert rows["dagger"]["n_seeds"] == "3" and rows["my_new_method"]["n_seeds"] == "2"
    assert rows["bc"]["interactive_success_mean"] == ""  # not applicable
    assert float(rows["dagger"]["paper_interactive_success"]) == pytest.approx(0.52)
    assert float(rows["bc"]["paper_autonomous_success"]) == pytest.approx(0.21)
    assert rows["my_new_method"]["paper_autonomous_success"] == ""  # not in the paper
    md = (out / "results.md").read_text()
    lo, hi = bootstrap_ci(inter)
    assert (
        f"| aperture | dagger | 3 | {100 * np.mean(inter):.1f} ± {100 * np.std(inter, ddof=1):.1f}% "
        f"[{100 * lo:.1f}, {100 * hi:.1f}] |"
    ) in md
    assert "| 52% | 79% |" in md and "χ sensitivity" in md and "1.00e-04" in md


def test_stats_files_hold_the_tests_and_r_squared(report):
    result, out, _ = report
    data = json.loads((out / "stats.json").read_text())
    assert {(t["method"], t["field"]) for t in data["welch_tests"]} == {
        ("bc", "autonomous_success"),
        ("dagger", "interactive_success"),
        ("dagger", "autonomous_success"),
        ("my_new_method", "interactive_success"),
        ("my_new_method", "autonomous_success"),
    }
    fits = {(c["method"], c["field"]): c for c in data["chi_correlations"]}
    assert fits[("ensemble_dagger", "interactive_success")]["r_squared"] is None  # NaN → null in JSON
    assert 0 < fits[("dpiil_ucb", "interactive_success")]["r_squared"] <= 1
    md = (out / "stats.md").read_text()
    assert "Welch" in md and "r²" in md and "constant input" in md
    text = summary_text(result)
    assert "dpiil_ucb" in text and "ref" in text and len(text.splitlines()) < 30


def test_any_subset_of_methods(tmp_path):
    write_run(tmp_path, "my_new_method", 0, [0.5], [0.2, 0.4])
    write_run(tmp_path, "dagger", 0, [0.3], [0.2, 0.3])
    result = write_study_report(tmp_path, tmp_path / "out")
    assert [s.method for s in result["method_stats"]] == ["dagger", "my_new_method"]
    assert result["welch_tests"] == [] and any("no t-tests" in n for n in result["notes"])
    assert not (tmp_path / "out" / "fig3d_chi_sensitivity.png").exists()
    assert_real_png(tmp_path / "out" / "fig3c_interactive.png")


def test_env_without_paper_numbers_and_several_envs(tmp_path):
    write_run(tmp_path, "dpiil_ucb", 0, [0.5], [0.2, 0.4], env="maze")
    write_run(tmp_path, "dpiil_ucb", 0, [0.5], [0.2, 0.4])
    result = write_study_report(tmp_path, tmp_path / "out")
    assert result["papers"]["maze"] is None and result["papers"]["aperture"] is not None
    assert_real_png(tmp_path / "out" / "fig3c_interactive_maze.png")
    assert_real_png(tmp_path / "out" / "fig3c_autonomous_aperture.png")


def test_paper_reference_files_are_complete():
    aperture = load_paper_reference("aperture")
    assert aperture is not None
    assert aperture["interactive_success"] == {
        "bc": None,
        "dagger": 52,
        "ensemble_dagger": 73,
        "thrifty_dagger": 78,
        "hg_dagger": None,
        "dpiil_mu": 89,
        "dpiil_ucb": 96,
    }
    assert aperture["autonomous_success"] == {
        "bc": 21,
        "dagger": 79,
        "ensemble_dagger": 96,
        "thrifty_dagger": 95,
        "hg_dagger": 60,
        "dpiil_mu": 89,
        "dpiil_ucb": 100,
    }
    ring = load_paper_reference("ring")
    assert ring is not None
    assert ring["autonomous_success"]["dpiil_ucb"] == pytest.approx(93.3)
    assert all(v is None for m, v in ring["autonomous_success"].items() if m != "dpiil_ucb")
    assert load_paper_reference("no_such_env") is None


def test_no_runs_is_a_clear_error(tmp_path):
    with pytest.raises(FileNotFoundError, match="no finished run"):
        write_study_report(tmp_path, tmp_path / "out")


def _report_script():
    import dpiil_rl.cli.report as module

    return module


def test_entry_script_reads_one_or_several_roots():
    script = _report_script()
    assert script.run_roots("runs/a") == [Path("runs/a")]
    assert script.run_roots(["runs/a", "runs/b"]) == [Path("runs/a"), Path("runs/b")]
    assert script.run_roots("runs/a, runs/b") == [Path("runs/a"), Path("runs/b")]
    with pytest.raises(ValueError, match="runs = ''"):
        script.run_roots("")
    argv = ["report.py", "runs=a,b", "out=x", "runs=[a,b]", "runs='a,b'", "runs=a"]
    assert script.comma_list_override(argv) == [
        "report.py",
        "runs=[a,b]",
        "out=x",
        "runs=[a,b]",
        "runs='a,b'",
        "runs=a",
    ]


def test_entry_script_with_two_roots(tmp_path):
    write_study(tmp_path / "main")
    write_chi_study(tmp_path / "chi")
    proc = run_script("report", f"runs={tmp_path / 'main'},{tmp_path / 'chi'}", timeout=120)
    out = tmp_path / "main" / "report"  # default: <first root>/report
    assert (out / "results.md").exists() and (out / "fig3d_chi_sensitivity.png").exists()
    assert "study report: 23 runs (12 fixed-χ)" in proc.stdout


def test_entry_script_names_bad_input(tmp_path):
    write_run(tmp_path, "dagger", 0, [0.5], [0.1, 0.2])
    proc = run_script("report", f"runs=[{tmp_path},{tmp_path / 'no_such_study'}]", check=False, timeout=120)
    assert proc.returncode == 2
    assert "no_such_study': no such directory" in proc.stderr and "Traceback" not in proc.stderr


def test_report_config_keys_are_commented():
    lines = (ROOT / "configs" / "report.yaml").read_text().splitlines()
    keys = [line for line in lines if line and not line.startswith((" ", "#", "hydra"))]
    assert keys and all("#" in line for line in keys)


def test_collapses_are_counted_per_run_name_so_knob_values_are_not_pooled():
    from dpiil_rl.study.study_report import collapses_section
    from dpiil_rl.study.study_runs import StudyRun

    def run(name, seed, successes):
        rows = [{"phase": "eval", "iteration": k, "success": s} for k, s in enumerate(successes)]
        return StudyRun(
            run_dir=Path(name) / f"seed_{seed}",
            env="aperture",
            method="dpiil_ucb",
            seed=seed,
            study="frontier",
            run_name=name,
            chi_fixed=None,
            config_data={},
            metrics=[],
            episodes=rows,
            recorded={},
        )

    section = collapses_section(
        [
            run("dpiil_ucb-q0.5", 1, [True, False]),
            run("dpiil_ucb-q0.9", 1, [True, True]),
            run("dpiil_ucb-q0.9", 2, [True]),
        ]
    )
    assert "| aperture | dpiil_ucb-q0.5 | 1 | 1 of 2 | seed_1 (k = 1) |" in section
    assert "| aperture | dpiil_ucb-q0.9 | 2 | 0 of 3 | – |" in section
    assert "In all: 1 of 5 evaluations" in section
