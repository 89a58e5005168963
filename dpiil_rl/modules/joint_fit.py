"""One minibatch loop for many fits at once: every ensemble member of every job is a slice of one stacked
network, so the fits of several runs (seeds batched in one process) cost about what one costs.

A :class:`FitJob` is one module's refit — its members' layers (:class:`EnsembleLinear`), its inputs and
targets, its settings and its own random generator. :func:`fit_jointly` stacks the jobs' members, draws
each job's minibatches from its own generator exactly as a fit alone would, and updates each member with
Adam at its job's learning rate (the job's schedule over the job's own number of steps; a job whose fit
is over is frozen while the others go on). A member's forward and backward pass is a slice of a batched
matmul and Adam is elementwise, so each job ends with the very numbers it would reach alone: a run's
results do not depend on which other runs were fitted beside it (tested bit for bit).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Sequence

import torch

from dpiil_rl.modules.ensemble_mlp import mlp_forward
from dpiil_rl.modules.fitting import FitSettings, member_batches

#: ``(prediction [M, b, out], target [M, b, out]) -> per-member loss [M]``
MemberLoss = Callable[[torch.Tensor, torch.Tensor], torch.Tensor]
BETAS, EPS = (0.9, 0.999), 1e-8  # Adam's defaults


@dataclass
class FitJob:
    """One module's fit: ``weights[l]`` / ``biases[l]`` are its layer ``l``'s parameters ``[E, in, out]`` and
    ``[E, 1, out]`` (updated in place at the end), ``x`` ``[n, in]`` and ``y`` ``[n, out]`` its data."""

    weights: list[torch.nn.Parameter]
    biases: list[torch.nn.Parameter]
    x: torch.Tensor
    y: torch.Tensor
    settings: FitSettings
    generator: torch.Generator
    bootstrap: torch.Tensor | None = None  # [E, n] each member's resample of the data, or None
    losses: list[float] = field(default_factory=list)  # the fit's loss curve (mean over its members), filled in

    @property
    def members(self) -> int:
        return int(self.weights[0].shape[0])

    @property
    def steps(self) -> int:
        return self.settings.num_steps(int(self.x.shape[0]))

    def batch_size(self) -> int:
        n = int(self.x.shape[0]) if self.bootstrap is None else int(self.bootstrap.shape[1])
        return min(self.settings.batch_size, n)

    def learning_rate(self, step: int) -> float:
        """The rate of step ``step`` (0-based) of this fit: ``lr``, annealed by the schedule over the fit's steps."""
        lr = float(self.settings.lr)
        if self.settings.schedule == "constant":
            return lr
        return lr * 0.5 * (1.0 + math.cos(math.pi * min(step, self.steps) / self.steps))


def fit_jointly(jobs: Sequence[FitJob], loss: MemberLoss) -> None:
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
        torch.cat([j.weights[layer].detach() for j in jobs]).clone().requires_grad_(True)
        for layer in range(len(jobs[0].weights))
    ]
    biases = [
        torch.cat([j.biases[layer].detach() for j in jobs]).clone().requires_grad_(True)
        for layer in range(len(jobs[0].biases))
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
    optimizer = _MemberAdam(params, decay)
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
            for layer, w in enumerate(j.weights):
                w.copy_(weights[layer][bounds[i] : bounds[i + 1]])
            for layer, bias in enumerate(j.biases):
                bias.copy_(biases[layer][bounds[i] : bounds[i + 1]])


class _MemberAdam:
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
