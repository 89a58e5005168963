"""A run's records do not depend on how it was launched: alone, or batched with other seeds in one process
(``hydra/launcher=lockstep``), they are the same, row for row."""

import json

from dpiil_rl.records.run_files import read_jsonl
from dpiil_rl.training.lockstep_launcher import split_batches
from tests.conftest import run_script

# the speed head of the actor's shape: each run's actor and speed head are fitted in one loop (joint_fit)
SETTINGS = ("experiment=smoke", "protocol.interactive_envs=3", "plots=false", "modules.speed_head.hidden=[64,64]")


def _strip(rows):
    return [{k: v for k, v in r.items() if not k.startswith("time/") and k != "wall_time_s"} for r in rows]


def test_batched_seeds_write_the_records_of_runs_alone(tmp_path):
    # seed 1 with a smaller dataset protocol than seed 0 would not batch: same settings, different seeds, whose
    # datasets differ in size at every refit (asserted below), so each batched fit draws from its own data
    run_script(
        "train",
        "-m",
        f"run_root={tmp_path / 'alone'}",
        "study=s",
        "method=dpiil_ucb,thrifty_dagger",
        "seed=0,1",
        *SETTINGS,
        "hydra/launcher=joblib",
        "hydra.launcher.n_jobs=2",
        timeout=600,
    )
    run_script(
        "train",
        "-m",
        f"run_root={tmp_path / 'batched'}",
        "study=s",
        "method=dpiil_ucb,thrifty_dagger",
        "seed=0,1",
        *SETTINGS,
        "hydra/launcher=lockstep",
        "hydra.launcher.n_jobs=1",
        timeout=600,
    )
    for method in ("dpiil_ucb", "thrifty_dagger"):
        sizes = [
            [
                r["dataset_size"]
                for r in read_jsonl(tmp_path / "alone" / "s" / "aperture" / method / f"seed_{s}" / "metrics.jsonl")
            ]
            for s in range(2)
        ]
        assert sizes[0][1:] != sizes[1][1:], (method, sizes)  # the seeds collected different data
        for seed in range(2):
            a = tmp_path / "alone" / "s" / "aperture" / method / f"seed_{seed}"
            b = tmp_path / "batched" / "s" / "aperture" / method / f"seed_{seed}"
            assert (a / "episodes.jsonl").read_text() == (b / "episodes.jsonl").read_text()
            assert _strip(read_jsonl(a / "metrics.jsonl")) == _strip(read_jsonl(b / "metrics.jsonl"))
            assert _strip([json.loads((a / "summary.json").read_text())]) == _strip(
                [json.loads((b / "summary.json").read_text())]
            )
            assert (b / ".hydra" / "config.yaml").exists()


def test_batches_fill_every_worker():
    assert split_batches([[0, 1, 2, 3, 4, 5, 6, 7, 8, 9]], max_batch=10, workers=2) == [
        [0, 1, 2, 3, 4],
        [5, 6, 7, 8, 9],
    ]
    assert split_batches([[0, 1, 2], [3, 4, 5]], max_batch=2, workers=2) == [[0, 1], [2], [3, 4], [5]]
    assert split_batches([[0]], max_batch=10, workers=4) == [[0]]
