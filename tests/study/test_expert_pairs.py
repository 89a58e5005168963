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


def test_the_dataset_of_a_compact_checkpoint_is_read_whole(tmp_path):
    import torch
    from tensordict import TensorDict

    from dpiil_rl.data.buffer import make_buffer
    from dpiil_rl.records.checkpoints import checkpoint_dir, write_checkpoint

    buffer = make_buffer(tmp_path / "run", 1_000)
    frames = TensorDict({"observation": torch.arange(12.0).reshape(6, 2)}, batch_size=[6])
    buffer.extend(frames)
    trainer: Any = SimpleNamespace(state_dict=lambda: {}, buffers=lambda: {"buffer": buffer})
    write_checkpoint(trainer, checkpoint_dir(tmp_path / "run", 0))  # the buffer's 6 frames, not 1,000 rows
    data = load_dataset(tmp_path / "run", 1_000)
    assert data.shape == (6,) and torch.equal(data["observation"], frames["observation"])
