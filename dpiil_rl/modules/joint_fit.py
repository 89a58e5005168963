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
from dpiil_rl.modules.fitting import FitSettings
from dpiil_rl.modules.fused_adam import fused_adam_step

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


def draw_batches(job: FitJob) -> torch.Tensor:
    """Every step's minibatch indices of ``job`` ``[steps, E, b]``, drawn now from its generator: the numbers and
    the generator's state afterwards are those of one :func:`~dpiil_rl.modules.fitting.member_batches` draw per
    step (CPU ``randint`` fills a tensor from the stream element by element, tested), so a run's later draws (its
    speed head's initialisation after its actor's minibatches) do not depend on when the fit loop runs."""
    n = int(job.x.shape[0]) if job.bootstrap is None else int(job.bootstrap.shape[1])
    draws = torch.randint(0, n, (job.steps, job.members, job.batch_size()), generator=job.generator)
    if job.bootstrap is None:
        return draws
    return torch.gather(job.bootstrap.unsqueeze(0).expand(job.steps, -1, -1), 2, draws)


def fit_jointly(
    jobs: Sequence[FitJob],
    loss: MemberLoss | Sequence[MemberLoss],
    batches: Sequence[torch.Tensor] | None = None,
) -> None:
    """Fit every job (same layer shapes and batch size) in one loop; fills ``job.losses``, writes the
    parameters back into each job's tensors.

    ``loss`` is every job's loss, or one per job (a run's actor and speed head in one loop: consecutive jobs
    with the same loss are one slice of the stacked network's output). ``batches`` are the jobs' minibatch
    indices drawn beforehand (:func:`draw_batches`); without them they are drawn here, job by job. A job whose
    fit is over leaves the stack (its members are written back) and the others go on with fewer members:
    every operation is per member (a slice of a batched matmul, an elementwise Adam), so each job ends with
    the numbers of its fit alone."""
    if not jobs:
        return
    if len({j.batch_size() for j in jobs}) != 1 or len({tuple(w.shape[1:] for w in j.weights) for j in jobs}) != 1:
        raise ValueError("fit_jointly: jobs fitted together need the same layer shapes and batch size")
    losses = [loss] * len(jobs) if callable(loss) else list(loss)
    if len(losses) != len(jobs):
        raise ValueError(f"fit_jointly: {len(losses)} losses for {len(jobs)} jobs")
    draws = list(batches) if batches is not None else [draw_batches(j) for j in jobs]
    steps = [j.steps for j in jobs]
    total, b = max(steps), jobs[0].batch_size()
    cols = [0, *torch.tensor([j.members for j in jobs]).cumsum(0).tolist()]  # each job's member columns
    # every job's inputs in one tensor; targets in one tensor per loss (their widths may differ)
    x_all = torch.cat([j.x for j in jobs]).float()
    y_parts: dict[int, list[torch.Tensor]] = {}
    y_off = []
    for j, fn in zip(jobs, losses):
        part = y_parts.setdefault(id(fn), [])
        y_off.append(sum(int(p.shape[0]) for p in part))
        part.append(j.y)
    y_all = {key: torch.cat(parts).float() for key, parts in y_parts.items()}
    # each member's rows of x and of its loss's targets, and its learning rate, at every step (0 after its fit)
    x_idx = torch.zeros(total, cols[-1], b, dtype=torch.long)
    y_idx = torch.zeros(total, cols[-1], b, dtype=torch.long)
    rates = torch.zeros(total, cols[-1], dtype=torch.float32)
    x_start = 0
    for i, j in enumerate(jobs):
        x_idx[: steps[i], cols[i] : cols[i + 1]] = draws[i] + x_start
        y_idx[: steps[i], cols[i] : cols[i + 1]] = draws[i] + y_off[i]
        rates[: steps[i], cols[i] : cols[i + 1]] = torch.tensor(
            [j.learning_rate(t) for t in range(steps[i])], dtype=torch.float32
        ).unsqueeze(1)
        x_start += int(j.x.shape[0])
        j.losses = []
    net = _Stack(jobs, losses, cols)
    for t in range(total):
        if any(s == t for s in steps):  # fits that are over leave the stack
            net.keep([i for i in net.order if steps[i] > t])
        xi, yi, rate = (
            (x_idx[t], y_idx[t], rates[t])
            if net.pick is None
            else (x_idx[t][net.pick], y_idx[t][net.pick], rates[t][net.pick])
        )
        pred = mlp_forward(net.weights, net.biases, x_all[xi])
        parts = [fn(pred[a:z], y_all[id(fn)][yi[a:z]]) for a, z, fn in net.segments]
        per_member = parts[0] if len(parts) == 1 else torch.cat(parts)
        grads = torch.autograd.grad(per_member.sum(), net.params)
        net.adam(grads, t + 1, rate)
        net.rows.append(per_member.detach())
    net.keep([])


class _Stack:
    """The members of the jobs still fitting side by side (``order``: their jobs; ``pick``: their columns among
    all jobs' members, None while every job is in), their Adam moments and their losses since the last change.
    :meth:`keep` writes the members of the jobs that leave back into their own tensors."""

    def __init__(self, jobs: Sequence[FitJob], losses: Sequence[MemberLoss], cols: Sequence[int]) -> None:
        self.jobs, self.losses, self.cols = jobs, losses, cols
        self.order = list(range(len(jobs)))
        self.pick: torch.Tensor | None = None
        layers = range(len(jobs[0].weights))
        self.weights = [torch.cat([j.weights[k].detach() for j in jobs]).clone().requires_grad_(True) for k in layers]
        self.biases = [torch.cat([j.biases[k].detach() for j in jobs]).clone().requires_grad_(True) for k in layers]
        self.moments = [(torch.zeros_like(p), torch.zeros_like(p)) for p in self.params]
        self.rows: list[torch.Tensor] = []  # each step's per-member losses since the stack last changed
        self._layout()

    @property
    def params(self) -> list[torch.Tensor]:
        return [*self.weights, *self.biases]

    def _layout(self) -> None:
        """Member ranges of consecutive jobs with one loss (``segments``) and the members' weight decay."""
        self.segments: list[tuple[int, int, MemberLoss]] = []
        start = 0
        for i in self.order:
            end = start + self.jobs[i].members
            if self.segments and self.segments[-1][2] is self.losses[i]:
                self.segments[-1] = (self.segments[-1][0], end, self.losses[i])
            else:
                self.segments.append((start, end, self.losses[i]))
            start = end
        decay = torch.cat(
            [torch.full((self.jobs[i].members,), float(self.jobs[i].settings.weight_decay)) for i in self.order]
        )
        self.decay = decay.reshape(-1, 1, 1) if bool((decay != 0).any()) else None

    def keep(self, order: list[int]) -> None:
        """Go on with the jobs ``order`` only: the others' members are written back, their losses recorded."""
        if order == self.order:
            return
        starts = [0, *torch.tensor([self.jobs[i].members for i in self.order]).cumsum(0).tolist()]
        rows = {i: (starts[k], starts[k + 1]) for k, i in enumerate(self.order)}
        if self.rows:  # the losses of the steps since the last change, one .tolist() (the same float32 values)
            values = torch.stack(self.rows).tolist()
            for i in self.order:
                a, z = rows[i]
                self.jobs[i].losses += [sum(v[a:z]) / (z - a) for v in values]
            self.rows = []
        with torch.no_grad():
            for i in self.order:
                if i in order:
                    continue
                a, z = rows[i]
                for k, w in enumerate(self.jobs[i].weights):
                    w.copy_(self.weights[k][a:z])
                for k, bias in enumerate(self.jobs[i].biases):
                    bias.copy_(self.biases[k][a:z])
        self.order = list(order)
        if not order:
            return
        keep = torch.cat([torch.arange(*rows[i]) for i in order])
        with torch.no_grad():
            self.weights = [w[keep].clone().requires_grad_(True) for w in self.weights]
            self.biases = [b[keep].clone().requires_grad_(True) for b in self.biases]
            self.moments = [(m[keep].clone(), v[keep].clone()) for m, v in self.moments]
        self.pick = torch.cat([torch.arange(self.cols[i], self.cols[i + 1]) for i in order])
        self._layout()

    def adam(self, grads: Sequence[torch.Tensor], step: int, rate: torch.Tensor) -> None:
        """Adam (Kingma & Ba; L2 weight decay as ``torch.optim.Adam``) with a learning rate per member (``rate``
        ``[M]``), in one compiled pass per tensor with the bits of torch's elementwise calls
        (:mod:`~dpiil_rl.modules.fused_adam`)."""
        b1, b2 = BETAS
        c1, c2 = 1.0 - b1**step, math.sqrt(1.0 - b2**step)
        fused_adam_step(self.params, grads, self.moments, rate / c1, self.decay, BETAS, c2, EPS)
