"""A long evaluation run a few simulations at a time gives the records of all its episodes side by side."""

from __future__ import annotations

import pytest
import torch

from dpiil_rl.modules.ensemble_actor import EnsembleActor
from dpiil_rl.training.evaluation import chunk_sizes


@pytest.mark.parametrize(
    ("episodes", "max_envs", "sizes"),
    [(100, 20, [20] * 5), (100, 30, [25] * 4), (7, 3, [3, 2, 2]), (3, 2, [3]), (10, 10, [10]), (1, 2, [1])],
)
def test_chunks_are_even_at_most_max_envs_and_never_a_single_env(episodes, max_envs, sizes):
    got = chunk_sizes(episodes, max_envs)
    assert got == sizes and sum(got) == episodes


def test_padded_rows_are_the_rows_of_the_whole_batch():
    """With ``pad_rows`` and ``pad_offset`` a chunk's actions are bit for bit those its rows get in the batch of
    all rows, for every chunk size (without them a batch of 1 or 3 rows takes other matrix kernels on some CPUs)."""
    torch.manual_seed(0)
    actor = EnsembleActor(
        -torch.ones(40), torch.ones(40), -torch.ones(7), torch.ones(7), num_members=5, hidden=[256, 256]
    )
    obs = torch.rand(100, 40) * 2 - 1
    whole = actor.members(obs)
    actor.pad_rows = 100
    for size in (1, 3, 7, 20, 33):
        chunks = []
        for i in range(0, 100, size):
            actor.pad_offset = i
            chunks.append(actor.members(obs[i : i + size]))
        assert torch.equal(torch.cat(chunks), whole), size


def test_padded_rows_get_the_mean_and_variance_of_the_whole_batch():
    """The policy's action (the mean over the members) and σ²_θ of a chunk's rows are bit for bit those of the
    batch of all rows: the mean over the members takes other paths for other batch sizes (measured: thousands of
    differing rows between 20 rows alone and the same rows among 100), so it is taken over the padded batch."""
    from tensordict import TensorDict

    torch.manual_seed(0)
    actor = EnsembleActor(-torch.ones(40), torch.ones(40), -torch.ones(7), torch.ones(7), num_members=5, hidden=[64])
    obs = torch.rand(100, 40) * 2 - 1
    whole = actor(TensorDict({"observation": obs}, batch_size=[100]))
    actor.pad_rows = 100
    for size in (2, 20, 33):
        parts = []
        for i in range(0, 100, size):
            actor.pad_offset = i
            parts.append(actor(TensorDict({"observation": obs[i : i + size]}, batch_size=[len(obs[i : i + size])])))
        for key in ("policy_action", "action_var", "action_members"):
            assert torch.equal(torch.cat([p[key] for p in parts]), whole[key]), (size, key)
    actor.pad_rows = None  # and without padding the rows of a smaller batch do differ (why the padding is there)
    alone = actor(TensorDict({"observation": obs[:20]}, batch_size=[20]))
    assert not torch.equal(alone["policy_action"], whole["policy_action"][:20])
