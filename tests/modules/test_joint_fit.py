"""Fits batched in one loop end exactly where each would alone (a run's results do not depend on the runs
fitted beside it)."""

import copy
import math
from typing import Sequence

import torch

from dpiil_rl.modules.ensemble_actor import EnsembleActor, action_loss
from dpiil_rl.modules.ensemble_mlp import mlp_forward
from dpiil_rl.modules.fitting import FitSettings, member_batches
from dpiil_rl.modules.joint_fit import BETAS, EPS, FitJob, MemberLoss, draw_batches, fit_jointly
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


def _actor_jobs(seed_offset=0):
    settings = [
        FitSettings(epochs=3, batch_size=32, lr=3e-3, weight_decay=1e-4),
        FitSettings(steps=25, batch_size=32, lr=1e-3),
        FitSettings(epochs=4, batch_size=32, lr=2e-3, schedule="constant"),
    ]
    jobs = []
    for i, (n, s) in enumerate(zip([150, 90, 230], settings)):
        torch.manual_seed(i)
        actor = EnsembleActor(
            LOW, HIGH, -torch.ones(2), torch.ones(2), num_members=3, hidden=(16, 16), bootstrap=(i == 1)
        )
        obs, act, _ = _data(n, i)
        jobs.append(actor.fit_job(obs, act, s, torch.Generator().manual_seed(10 + i + seed_offset)))
    return jobs


def test_the_loop_ends_where_the_loop_it_replaced_ended():
    old, new = _actor_jobs(), _actor_jobs()
    _reference_fit(old, action_loss)
    fit_jointly(new, action_loss)
    for a, b in zip(old, new):
        assert all(torch.equal(x, y) for x, y in zip([*a.weights, *a.biases], [*b.weights, *b.biases]))
        assert a.losses == b.losses
        assert torch.equal(a.generator.get_state(), b.generator.get_state())


def test_a_runs_actor_and_speed_head_in_one_loop_end_where_their_fits_alone_end():
    def build():
        torch.manual_seed(0)
        actor = EnsembleActor(LOW, HIGH, -torch.ones(2), torch.ones(2), num_members=3, hidden=(16, 16))
        head = SpeedHead(LOW, HIGH, hidden=(16, 16))
        return actor, head

    obs, act, v = _data(120, 3)
    actor_fit, speed_fit = FitSettings(epochs=3, batch_size=16, lr=3e-3), FitSettings(steps=40, batch_size=16)
    actor, head = build()
    g = torch.Generator().manual_seed(5)
    actor_losses = actor.fit(obs, act, actor_fit, g)  # alone: the actor, then the speed head, one generator
    speed_losses = head.fit(obs, v, speed_fit, g)
    alone = _params(actor) + _params(head)
    actor, head = build()
    g2 = torch.Generator().manual_seed(5)
    a_job = actor.fit_job(obs, act, actor_fit, g2)
    a_batches = draw_batches(a_job)
    s_job = head.fit_job(obs, v, speed_fit, g2)
    s_batches = draw_batches(s_job)
    fit_jointly([a_job, s_job], [action_loss, speed_loss(head.min_sigma)], [a_batches, s_batches])
    assert all(torch.equal(x, y) for x, y in zip(alone, _params(actor) + _params(head)))
    assert (a_job.losses, s_job.losses) == (actor_losses, speed_losses)
    assert torch.equal(g.get_state(), g2.get_state())


def test_batches_drawn_beforehand_are_the_draws_step_by_step():
    for job in _actor_jobs():
        before = job.generator.get_state()
        ahead = draw_batches(job)
        g = torch.Generator()
        g.set_state(before)
        n = int(job.x.shape[0])
        steps = [member_batches(n, job.members, job.settings.batch_size, g, job.bootstrap) for _ in range(job.steps)]
        assert torch.equal(ahead, torch.stack(steps))
        assert torch.equal(job.generator.get_state(), g.get_state())


# ------------------------------------------------------------------ the loop as it was before the fits shared
# one loop with a stack that sheds finished jobs (commit 5818c2d): a fixed stack, frozen members masked,
# minibatches drawn step by step, Adam one tensor at a time. The loop now must end where this one did.
def _reference_fit(jobs: Sequence[FitJob], loss: MemberLoss) -> None:
    """Fit every job (same architecture and batch size) in one loop; fills ``job.losses``, writes the
    parameters back into each job's tensors."""
    if not jobs:
        return
    if len({j.batch_size() for j in jobs}) != 1 or len({tuple(w.shape[1:] for w in j.weights) for j in jobs}) != 1:
        raise ValueError("fit_jointly: jobs fitted together need the same layer shapes and batch size")
    members = [j.members for j in jobs]
    bounds = [0, *torch.tensor(members).cumsum(0).tolist()]
    offsets = [0, *torch.tensor([int(j.x.shape[0]) for j in jobs]).cumsum(0).tolist()]
    x_all = torch.cat([j.x for j in jobs]).float()
    y_all = torch.cat([j.y for j in jobs]).float()
    weights = [
        torch.cat([j.weights[k].detach() for j in jobs]).clone().requires_grad_(True)
        for k in range(len(jobs[0].weights))
    ]
    biases = [
        torch.cat([j.biases[k].detach() for j in jobs]).clone().requires_grad_(True) for k in range(len(jobs[0].biases))
    ]
    params = [*weights, *biases]
    steps = [j.steps for j in jobs]
    total = max(steps)
    # every member's learning rate at every step (0 once its job's fit is over: frozen) and weight decay
    rates = torch.zeros(total, bounds[-1], dtype=torch.float32)
    for i, j in enumerate(jobs):
        rates[: steps[i], bounds[i] : bounds[i + 1]] = torch.tensor(
            [j.learning_rate(t) for t in range(steps[i])]
        ).unsqueeze(1)
    decay = torch.cat([torch.full((m,), float(j.settings.weight_decay)) for m, j in zip(members, jobs)])
    optimizer = _ReferenceAdam(params, decay)
    b = jobs[0].batch_size()
    idx = torch.empty(bounds[-1], b, dtype=torch.long)
    for j in jobs:
        j.losses = []
    for t in range(total):
        mask = (rates[t] > 0).float() if t >= min(steps) else None  # before any fit ends every member is on
        for i, j in enumerate(jobs):
            if t < steps[i]:  # each job draws its minibatches from its own generator, as alone
                idx[bounds[i] : bounds[i + 1]] = (
                    member_batches(int(j.x.shape[0]), j.members, j.settings.batch_size, j.generator, j.bootstrap)
                    + offsets[i]
                )
            else:
                idx[bounds[i] : bounds[i + 1]] = offsets[i]
        per_member = loss(mlp_forward(weights, biases, x_all[idx]), y_all[idx])  # [M]
        objective = per_member.sum() if mask is None else (per_member * mask).sum()
        grads = torch.autograd.grad(objective, params)
        optimizer.step(grads, t + 1, rates[t])
        values = per_member.detach().tolist()
        for i, j in enumerate(jobs):
            if t < steps[i]:
                j.losses.append(sum(values[bounds[i] : bounds[i + 1]]) / j.members)
    with torch.no_grad():
        for i, j in enumerate(jobs):
            for k, w in enumerate(j.weights):
                w.copy_(weights[k][bounds[i] : bounds[i + 1]])
            for k, bias in enumerate(j.biases):
                bias.copy_(biases[k][bounds[i] : bounds[i + 1]])


class _ReferenceAdam:
    """Adam (Kingma & Ba; L2 weight decay as ``torch.optim.Adam``) with a learning rate per member. A member
    at rate 0 keeps its parameters exactly (its fit is over; its moments are never read again)."""

    def __init__(self, params: Sequence[torch.Tensor], decay: torch.Tensor) -> None:
        self.params = list(params)
        self.shapes = [(-1,) + (1,) * (p.dim() - 1) for p in self.params]
        self.decay = [decay.reshape(s) for s in self.shapes] if bool((decay != 0).any()) else None
        self.moments = [(torch.zeros_like(p), torch.zeros_like(p)) for p in self.params]

    def step(self, grads: Sequence[torch.Tensor], step: int, rate: torch.Tensor) -> None:
        b1, b2 = BETAS
        c1, c2 = 1.0 - b1**step, math.sqrt(1.0 - b2**step)
        scaled = rate / c1
        with torch.no_grad():
            for n, (p, g, (m, v)) in enumerate(zip(self.params, grads, self.moments)):
                if self.decay is not None:
                    g = g + self.decay[n] * p
                m.mul_(b1).add_(g, alpha=1.0 - b1)
                v.mul_(b2).addcmul_(g, g, value=1.0 - b2)
                denom = v.sqrt().div_(c2).add_(EPS)
                p.sub_(m.div(denom).mul_(scaled.reshape(self.shapes[n])))
