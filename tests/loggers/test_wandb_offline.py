"""A run logged with wandb offline: what its dashboard will show, read back from the offline files."""

import json

import pytest

from dpiil_rl.loggers.wandb_offline import _records, offline_runs, read_offline_run
from dpiil_rl.records.run_files import read_jsonl
from tests.conftest import run_script, smoke_overrides


@pytest.fixture(scope="module")
def wandb_run(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("wandb") / "run"
    run_script(
        "train",
        *smoke_overrides(run_dir, "logger=wandb", "study=dash", "method=ensemble_dagger", "protocol.iterations=1"),
    )
    found = offline_runs(run_dir)
    assert len(found) == 1, found
    return run_dir, read_offline_run(found[0])


def test_group_job_type_and_config(wandb_run):
    _, run = wandb_run
    assert (run.project, run.group, run.job_type) == ("dpiil_rl", "dash", "ensemble_dagger")
    assert run.config["env"]["name"] == "aperture" and run.config["method"]["name"] == "ensemble_dagger"


def test_namespaced_metrics_every_iteration(wandb_run):
    run_dir, run = wandb_run
    keys = run.history_keys()
    for key in (
        "eval/autonomous_success",
        "interaction/interactive_success",
        "interaction/interventions",
        "train/chi",
        "train/actor_mse",
        "time/elapsed_s",
        "time/refit_s",
    ):
        assert key in keys, key
    auto = [row["eval/autonomous_success"] for row in run.history if "eval/autonomous_success" in row]
    metrics = read_jsonl(run_dir / "metrics.jsonl")
    assert auto == [m["autonomous_success"] for m in metrics]  # the dashboard shows the run files' numbers


def test_episode_table_media_and_summary(wandb_run):
    run_dir, run = wandb_run
    tables = [p for p in run.media("table") if p.suffix == ".json"]
    assert len(tables) == 1
    table = json.loads(tables[0].read_text())
    episodes = read_jsonl(run_dir / "episodes.jsonl")
    assert len(table["data"]) == len(episodes) and "phase" in table["columns"] and "success" in table["columns"]
    images = {p.name.rsplit("_", 2)[0] for p in run.media("images") if p.suffix == ".png"}
    assert {"learning_curve", "maps_initial", "maps_final"} <= images
    summary = json.loads((run_dir / "summary.json").read_text())
    assert run.summary["autonomous_success"] == summary["autonomous_success"]
    assert run.summary["method"] == "ensemble_dagger"


def test_reader_rejects_other_files(tmp_path):
    bad = tmp_path / "run-x.wandb"
    bad.write_bytes(b"not a wandb file at all")
    with pytest.raises(ValueError, match="not a wandb run file"):
        list(_records(bad.read_bytes()))
