import torch

from dpiil_rl.data.splits import episode_uniform, heldout_episodes


def test_whole_episodes_are_held_out_by_a_stable_hash():
    episode = torch.tensor([0, 0, 0, 1, 1, 2, 2, 2, 2, 3, 4, 4] + [e for e in range(5, 60) for _ in range(3)])
    mask = heldout_episodes(episode, 0.3, salt=7)
    held = set(episode[mask].tolist())
    assert 0.15 < len(held) / 60 < 0.45  # about 30% of 60 episodes
    assert all(bool(mask[episode == e].all()) for e in held)  # every frame of a held-out episode
    # D grows: the episodes held out before stay held out, the policy's episodes stay the policy's
    grown = torch.cat([episode, torch.tensor([60, 60, 61, 62, 62])])
    held_after = set(grown[heldout_episodes(grown, 0.3, salt=7)].tolist())
    assert held <= held_after and not (held_after - held) & set(range(60))
    assert set(episode[heldout_episodes(episode, 0.3, salt=8)].tolist()) != held  # another run, another split


def test_at_least_one_episode_stays_for_the_policy_and_one_is_held_out():
    two = torch.tensor([5, 5, 7])
    for salt in range(5):
        for fraction in (0.01, 0.99):
            held = set(two[heldout_episodes(two, fraction, salt)].tolist())
            assert held in ({5}, {7})


def test_nothing_is_held_out_of_one_episode_or_at_fraction_zero():
    assert not bool(heldout_episodes(torch.tensor([3, 3, 3]), 0.5, 0).any())
    assert not bool(heldout_episodes(torch.tensor([1, 2, 3]), 0.0, 0).any())


def test_the_hash_is_uniform():
    import numpy as np

    u = episode_uniform(np.arange(20000), 3)
    assert 0.0 <= u.min() and u.max() < 1.0 and abs(u.mean() - 0.5) < 0.01
