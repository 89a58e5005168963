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
