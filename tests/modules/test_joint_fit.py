"""Fits batched in one loop end exactly where each would alone (a run's results do not depend on the runs
fitted beside it)."""

import copy

import torch

from dpiil_rl.modules.ensemble_actor import EnsembleActor, action_loss
from dpiil_rl.modules.fitting import FitSettings
from dpiil_rl.modules.joint_fit import fit_jointly
from dpiil_rl.modules.speed_head import SpeedHead, speed_loss

LOW, HIGH = torch.zeros(2), torch.full((2,), 10.0)


def _data(n, seed):
    g = torch.Generator().manual_seed(seed)
    obs = torch.rand(n, 2, generator=g) * 10
    return (
        obs,
        0.4 * torch.tanh(obs - 5) + 0.05 * torch.randn(n, 2, generator=g),
        (torch.rand(n, 1, generator=g) + 0.1) ** 2,
    )


def _params(module):
    return [p.detach().clone() for p in module.parameters()]


def test_joint_actor_fits_match_each_fit_alone_bit_for_bit():
    settings = FitSettings(epochs=3, batch_size=32, lr=3e-3, weight_decay=1e-4)
    sizes = [150, 90, 230]  # different data sizes: different numbers of steps, the shorter fits freeze first
    alone, losses = [], []
    for i, n in enumerate(sizes):
        actor = EnsembleActor(
            LOW, HIGH, -torch.ones(2), torch.ones(2), num_members=3, hidden=(16, 16), bootstrap=(i == 1)
        )
        obs, act, _ = _data(n, i)
        losses.append(actor.fit(obs, act, settings, torch.Generator().manual_seed(10 + i)))
        alone.append(_params(actor))
    actors = [
        EnsembleActor(LOW, HIGH, -torch.ones(2), torch.ones(2), num_members=3, hidden=(16, 16), bootstrap=(i == 1))
        for i in range(3)
    ]
    jobs = [
        a.fit_job(*_data(n, i)[:2], settings, torch.Generator().manual_seed(10 + i))
        for i, (a, n) in enumerate(zip(actors, sizes))
    ]
    fit_jointly(jobs, action_loss)
    for i, actor in enumerate(actors):
        assert all(torch.equal(a, b) for a, b in zip(alone[i], _params(actor)))
        assert jobs[i].losses == losses[i]
    assert len({len(x) for x in losses}) == 3


def test_joint_speed_head_fits_match_each_fit_alone():
    settings = FitSettings(steps=40, batch_size=16)
    heads = [SpeedHead(LOW, HIGH, hidden=(8, 8)) for _ in range(2)]
    solo = copy.deepcopy(heads)
    for i, head in enumerate(solo):
        obs, _, v = _data(100 + 20 * i, i)
        head.fit(obs, v, settings, torch.Generator().manual_seed(i))
    jobs = []
    for i, head in enumerate(heads):
        obs, _, v = _data(100 + 20 * i, i)
        jobs.append(head.fit_job(obs, v, settings, torch.Generator().manual_seed(i)))
    fit_jointly(jobs, speed_loss(heads[0].min_sigma))
    for a, b in zip(solo, heads):
        assert all(torch.equal(x, y) for x, y in zip(_params(a), _params(b)))
        assert torch.equal(a.v_scale, b.v_scale)
