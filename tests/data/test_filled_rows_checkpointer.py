from pathlib import Path

import torch
from tensordict import TensorDict
from torchrl.data import LazyMemmapStorage, TensorDictReplayBuffer

from dpiil_rl.data.buffer import buffer_contents, make_buffer


def _frames(n: int, start: int = 0) -> TensorDict:
    x = torch.arange(start, start + n, dtype=torch.float32)
    return TensorDict(
        {
            "observation": x[:, None].repeat(1, 4),
            "expert_action": x[:, None].repeat(1, 2),
            ("next", "done"): torch.zeros(n, 1, dtype=torch.bool),
        },
        batch_size=[n],
    )


def _bytes(path: Path) -> int:
    return sum(f.stat().st_size for f in path.rglob("*") if f.is_file())


def test_a_dump_holds_the_frames_written_not_the_capacity(tmp_path):
    buffer = make_buffer(tmp_path / "run", 100_000)
    buffer.extend(_frames(30))
    buffer.dumps(str(tmp_path / "dump"))
    # 30 frames of 7 numbers and an index: a few kB with the metadata; the capacity would be 3.3 MB
    assert _bytes(tmp_path / "dump") < 10_000


def test_a_compact_dump_resumes_like_the_buffer_it_was_taken_from(tmp_path):
    buffer = make_buffer(tmp_path / "a", 1_000)
    buffer.extend(_frames(30))
    buffer.dumps(str(tmp_path / "dump"))
    resumed = make_buffer(tmp_path / "b", 1_000)
    resumed.loads(str(tmp_path / "dump"))
    assert len(resumed) == 30 and (buffer_contents(resumed) == buffer_contents(buffer)).all()
    buffer.extend(_frames(5, 30))  # the writer's cursor came back too: new frames land after the old ones
    resumed.extend(_frames(5, 30))
    assert len(resumed) == 35 and (buffer_contents(resumed) == buffer_contents(buffer)).all()


def test_a_full_capacity_dump_from_torchrl_still_loads(tmp_path):
    old = TensorDictReplayBuffer(storage=LazyMemmapStorage(1_000, scratch_dir=str(tmp_path / "old")))
    old.extend(_frames(7))
    old.dumps(str(tmp_path / "dump"))  # torchrl's own checkpointer: all 1,000 rows
    assert _bytes(tmp_path / "dump") > 1_000 * 6 * 4
    resumed = make_buffer(tmp_path / "new", 1_000)
    resumed.loads(str(tmp_path / "dump"))
    assert len(resumed) == 7 and (buffer_contents(resumed) == buffer_contents(old)).all()
