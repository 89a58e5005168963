import torch

from dpiil_rl.data.splits import heldout_episodes


def test_whole_episodes_are_held_out():
    episode = torch.tensor([0, 0, 0, 1, 1, 2, 2, 2, 2, 3, 4, 4])
    mask = heldout_episodes(episode, 0.4, torch.Generator().manual_seed(0))
    held = set(episode[mask].tolist())
    assert len(held) == 2  # round(0.4 * 5 episodes)
    assert all(bool(mask[episode == e].all()) for e in held)  # every frame of a held-out episode
    assert not bool(mask[~torch.isin(episode, torch.tensor(sorted(held)))].any())


def test_at_least_one_episode_stays_for_the_policy_and_one_is_held_out():
    two = torch.tensor([5, 5, 7])
    assert int(heldout_episodes(two, 0.9, torch.Generator().manual_seed(1)).sum()) in (1, 2)
    assert set(two[heldout_episodes(two, 0.9, torch.Generator().manual_seed(1))].tolist()) in ({5}, {7})
    assert set(two[heldout_episodes(two, 0.01, torch.Generator().manual_seed(1))].tolist()) in ({5}, {7})


def test_nothing_is_held_out_of_one_episode_or_at_fraction_zero():
    assert not bool(heldout_episodes(torch.tensor([3, 3, 3]), 0.5, torch.Generator()).any())
    assert not bool(heldout_episodes(torch.tensor([1, 2, 3]), 0.0, torch.Generator()).any())
