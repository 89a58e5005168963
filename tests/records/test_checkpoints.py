"""Buffers in checkpoints: an empty buffer is a marker, a reloaded one is saved again whole and quietly."""

import warnings

import pytest
import torch
from tensordict import TensorDict

from dpiil_rl.data.buffer import buffer_contents, make_buffer
from dpiil_rl.records.checkpoints import dump_buffer, load_buffer


def frames(n, start=0):
    return TensorDict({"observation": torch.arange(start, start + n, dtype=torch.float32).unsqueeze(-1)}, [n])


def test_an_empty_buffer_is_saved_as_a_marker_and_loads_empty(tmp_path):
    ckpt = tmp_path / "ckpt"
    ckpt.mkdir()
    dump_buffer(make_buffer(tmp_path / "a", 10), ckpt, "buffer")  # torchrl alone raises on an empty storage
    assert (ckpt / "buffer.empty").exists() and not (ckpt / "buffer").exists()
    again = make_buffer(tmp_path / "b", 10)
    load_buffer(again, ckpt, "buffer")
    assert len(again) == 0
    again.extend(frames(3))  # and it fills as a fresh one does
    assert buffer_contents(again)["observation"].reshape(-1).tolist() == [0.0, 1.0, 2.0]


def test_a_reloaded_buffer_saved_before_new_frames_is_whole_and_raises_no_warning(tmp_path):
    first, second = tmp_path / "c1", tmp_path / "c2"
    first.mkdir()
    second.mkdir()
    buffer = make_buffer(tmp_path / "a", 10)
    buffer.extend(frames(4))
    dump_buffer(buffer, first, "buffer")
    reloaded = make_buffer(tmp_path / "b", 10)
    load_buffer(reloaded, first, "buffer")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # torchrl's "last_cursor is None" would fail here
        dump_buffer(reloaded, second, "buffer")
    last = make_buffer(tmp_path / "d", 10)
    load_buffer(last, second, "buffer")
    last.extend(frames(2, start=4))  # continues after the 4 saved frames
    assert buffer_contents(last)["observation"].reshape(-1).tolist() == [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]


def test_a_checkpoint_without_the_buffer_is_named(tmp_path):
    with pytest.raises(FileNotFoundError, match="no experience/ inside"):
        load_buffer(make_buffer(tmp_path / "a", 10), tmp_path, "experience")


def _checkpoint(run_dir, k):
    path = run_dir / "checkpoints" / f"iter_{k:03d}"
    path.mkdir(parents=True)
    (path / "state.pt").write_bytes(b"")
    return path


def test_pruning_keeps_iteration_zero_the_newest_and_latest(tmp_path):
    from dpiil_rl.records.checkpoints import prune_checkpoints

    for k in range(5):
        _checkpoint(tmp_path, k)
    (tmp_path / "checkpoints" / "latest").write_text("iter_002\n")  # a pointer behind the newest is still kept
    (tmp_path / "checkpoints" / "iter_005.tmp").mkdir()  # an unfinished write is not an iteration checkpoint
    removed = prune_checkpoints(tmp_path, keep=1)
    assert sorted(p.name for p in removed) == ["iter_001", "iter_003"]
    left = sorted(p.name for p in (tmp_path / "checkpoints").iterdir())
    assert left == ["iter_000", "iter_002", "iter_004", "iter_005.tmp", "latest"]


@pytest.mark.parametrize("keep", [0, -1, True, "2"])
def test_a_bad_checkpoint_keep_is_named(keep):
    from dpiil_rl.hooks.checkpoint import CheckpointHook

    with pytest.raises(ValueError, match=r"checkpoint_keep = .*expected null \(keep all\) or an integer >= 1"):
        CheckpointHook(keep=keep)
