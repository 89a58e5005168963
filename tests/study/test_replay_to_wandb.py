"""``make dashboard``: a run that logged to CSV gets the offline wandb run it would have written live."""

import json
import shutil

import pytest

from dpiil_rl.loggers.wandb_offline import offline_runs, read_offline_run
from dpiil_rl.records.run_files import read_jsonl
from dpiil_rl.study.replay_to_wandb import REPLAYED_KEY
from tests.conftest import run_script, smoke_overrides


@pytest.fixture(scope="module")
def csv_run(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("replay") / "study" / "run"
    run_script(
        "train", *smoke_overrides(run_dir, "logger=csv", "study=replayed", "method=dpiil_ucb", "protocol.iterations=1")
    )
    assert not offline_runs(run_dir)
    return run_dir


def test_the_dashboard_run_holds_the_records(csv_run):
    out = run_script("dashboard", f"runs={csv_run.parent}")
    assert "1 offline wandb run(s) written" in out.stdout
    (found,) = offline_runs(csv_run)
    run = read_offline_run(found)
    assert (run.project, run.group, run.job_type, run.display_name) == (
        "dpiil_rl",
        "replayed",
        "dpiil_ucb",
        "aperture-dpiil_ucb-seed0",
    )
    assert run.config["env"]["name"] == "aperture" and run.config["method"]["name"] == "dpiil_ucb"
    metrics = read_jsonl(csv_run / "metrics.jsonl")
    success = [
        row["interaction/interactive_success"] for row in run.history if "interaction/interactive_success" in row
    ]
    assert success == [
        m["interactive_success"] for m in metrics if m["interactive_success"] is not None
    ]  # as a live run
    assert {"eval/autonomous_success", "train/chi", "time/elapsed_s"} <= run.history_keys()
    summary = json.loads((csv_run / "summary.json").read_text())
    assert run.summary["autonomous_success"] == summary["autonomous_success"] and run.summary[REPLAYED_KEY] is True
    (table,) = [p for p in run.media("table") if p.suffix == ".json"]
    assert len(json.loads(table.read_text())["data"]) == len(read_jsonl(csv_run / "episodes.jsonl"))
    images = {p.name.rsplit("_", 2)[0] for p in run.media("images") if p.suffix == ".png"}
    assert {"learning_curve", "maps_final"} <= images  # the run's own plots/


def test_a_second_time_skips_unless_forced_and_copied_records_get_a_drawn_curve(csv_run, tmp_path):
    again = run_script("dashboard", f"runs={csv_run}")
    assert "skipped (has a wandb run already" in again.stdout and len(offline_runs(csv_run)) == 1
    copied = tmp_path / "copied"  # records only, as in docs/results: no plots/, no wandb/
    copied.mkdir()
    for name in (".hydra", "episodes.jsonl", "metrics.jsonl", "summary.json"):
        (shutil.copytree if (csv_run / name).is_dir() else shutil.copy)(csv_run / name, copied / name)
    run_script("dashboard", f"runs={copied}", "force=true")
    (found,) = offline_runs(copied)
    assert [p.name.rsplit("_", 2)[0] for p in read_offline_run(found).media("images") if p.suffix == ".png"] == [
        "learning_curve"
    ]


def test_no_finished_run_is_named(tmp_path):
    proc = run_script("dashboard", f"runs={tmp_path}", check=False)
    assert proc.returncode != 0 and "no finished run below it" in proc.stderr
