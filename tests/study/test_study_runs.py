"""Loading a study: recomputed numbers, mismatch errors, unfinished and duplicate runs, method order."""

import json

import pytest

from dpiil_rl.study.study_runs import dataset_mismatches, load_run, load_study, method_order
from tests.study.synthetic_runs import write_chi_study, write_run, write_study


def test_loads_every_run_with_recomputed_numbers(tmp_path):
    dirs = write_study(tmp_path)
    runs = load_study(tmp_path)
    assert len(runs) == len(dirs) == 11
    dagger0 = next(r for r in runs if r.method == "dagger" and r.seed == 0)
    assert dagger0.summary["interactive_success"] == pytest.approx(0.55)  # (5 + 6) / 20 episodes
    assert dagger0.summary["autonomous_success"] == pytest.approx(0.8)  # the last iteration's evaluation
    assert [c["iteration"] for c in dagger0.curve] == [0, 1, 2]
    assert [c["autonomous_success"] for c in dagger0.curve] == pytest.approx([0.2, 0.6, 0.8])
    bc = next(r for r in runs if r.method == "bc")
    assert bc.summary["interactive_success"] is None and bc.chi_fixed is None
    assert dagger0.run_name == "dagger" and dagger0.env == "aperture"
    assert len(dagger0.paths()) == 3 + 20  # demos + interactive episodes


def test_chi_comes_from_summary_or_else_the_config(tmp_path):
    with_key = write_run(tmp_path / "a", "dpiil_ucb", 0, [0.5], [0.5, 0.5], chi_fixed=1e-4)
    without_key = write_run(tmp_path / "b", "dpiil_ucb", 0, [0.5], [0.5, 0.5], chi_fixed=3e-5, chi_in_summary=False)
    calibrated = write_run(tmp_path / "c", "dpiil_ucb", 0, [0.5], [0.5, 0.5], chi_in_summary=False)
    assert load_run(with_key).chi_fixed == pytest.approx(1e-4)
    assert load_run(without_key).chi_fixed == pytest.approx(3e-5)
    assert load_run(calibrated).chi_fixed is None


@pytest.mark.parametrize("field,value", [("interactive_success", 0.99), ("expert_actions", 1), ("collisions", 0)])
def test_summary_that_does_not_recompute_is_named(tmp_path, field, value):
    run_dir = write_run(tmp_path, "dagger", 3, [0.5, 0.5], [0.1, 0.2, 0.3])
    summary = json.loads((run_dir / "summary.json").read_text())
    summary[field] = value
    (run_dir / "summary.json").write_text(json.dumps(summary))
    with pytest.raises(ValueError, match=rf"seed_3.*summary.json {field} = {value}"):
        load_study(tmp_path)


def test_float_rounding_is_not_a_mismatch(tmp_path):
    run_dir = write_run(tmp_path, "dagger", 0, [1 / 3, 1 / 3], [0.1, 0.2, 0.3], n_interactive=3)  # 2 / 6
    summary = json.loads((run_dir / "summary.json").read_text())
    summary["interactive_success"] = round(summary["interactive_success"], 14)
    assert summary["interactive_success"] != 2 / 6
    (run_dir / "summary.json").write_text(json.dumps(summary))
    assert load_run(run_dir).summary["interactive_success"] == pytest.approx(summary["interactive_success"])


def test_metrics_row_that_does_not_recompute_is_named(tmp_path):
    run_dir = write_run(tmp_path, "dagger", 0, [0.5, 0.5], [0.1, 0.2, 0.3])
    rows = [json.loads(line) for line in (run_dir / "metrics.jsonl").read_text().splitlines()]
    rows[1]["autonomous_success"] = 0.9
    (run_dir / "metrics.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    with pytest.raises(ValueError, match="metrics.jsonl iteration 1 autonomous_success = 0.9"):
        load_run(run_dir)


def test_unfinished_runs_are_skipped_with_a_warning(tmp_path, capsys):
    write_study(tmp_path)
    killed = write_run(tmp_path, "dagger", 7, [0.5], [0.1, 0.2])
    (killed / "summary.json").unlink()
    runs = load_study(tmp_path)
    assert all(r.seed != 7 for r in runs) and len(runs) == 11
    err = capsys.readouterr().err
    assert "warning: skipping 1 unfinished run" in err and str(killed) in err


def test_several_roots_and_overlapping_roots(tmp_path):
    write_study(tmp_path / "main")
    write_chi_study(tmp_path / "chi")
    runs = load_study([tmp_path / "main", tmp_path / "chi", tmp_path / "chi" / "chi"])  # overlap: counted once
    assert len(runs) == 11 + 12
    assert sum(r.is_sensitivity for r in runs) == 12


def test_the_same_run_in_two_directories_is_an_error(tmp_path):
    write_run(tmp_path / "a", "dagger", 0, [0.5], [0.1, 0.2])
    write_run(tmp_path / "b", "dagger", 0, [0.5], [0.1, 0.2])
    with pytest.raises(ValueError, match="same run"):
        load_study(tmp_path)


def test_missing_root_is_named(tmp_path):
    with pytest.raises(FileNotFoundError, match="nowhere.*no such directory"):
        load_study([tmp_path, tmp_path / "nowhere"])


def test_method_order_is_the_papers_then_unknown_ones():
    assert method_order(["zeta", "dpiil_ucb", "bc", "alpha", "dagger"]) == [
        "bc",
        "dagger",
        "dpiil_ucb",
        "alpha",
        "zeta",
    ]


def test_a_dataset_that_holds_pairs_no_episode_records_is_noted(tmp_path):
    run_dir = write_run(tmp_path, "dagger", 0, [0.5, 0.5], [0.1, 0.2, 0.3])
    rows = [json.loads(line) for line in (run_dir / "metrics.jsonl").read_text().splitlines()]
    for r in rows:
        r["dataset_size"] = r["expert_actions"]
    (run_dir / "metrics.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    assert dataset_mismatches([load_run(run_dir)]) == []  # D = the recorded episodes' pairs
    for r in rows[1:]:
        r["dataset_size"] = r["expert_actions"] + 15  # frames of an episode a pause cut short, from iteration 1
    (run_dir / "metrics.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    (note,) = dataset_mismatches([load_run(run_dir)])
    assert (
        note.startswith("aperture/dagger/seed_0: its dataset holds +15 pairs beside the") and "from iteration 1" in note
    )
