"""Where expert pairs were collected: bad input is named (the ring counts are checked on a real run in
tests/training/test_ring_quick.py)."""

from types import SimpleNamespace
from typing import Any

import pytest

from dpiil_rl.study.expert_pairs import expert_pair_stages, load_dataset


def test_other_tasks_are_refused_by_name():
    with pytest.raises(ValueError, match=r"env = \['aperture'\]"):
        runs: Any = [SimpleNamespace(env="aperture", method="bc", run_dir="x")]  # a stand-in for a study run
        expert_pair_stages(runs)


def test_still_must_be_positive():
    with pytest.raises(ValueError, match="still = 0"):
        expert_pair_stages([], still=0)


def test_a_run_without_checkpoints_is_named(tmp_path):
    with pytest.raises(FileNotFoundError, match="no checkpoint with a buffer"):
        load_dataset(tmp_path, 10)
