"""Settings and batching shared by the supervised fits of the ensemble actor and the speed head."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Iterable

import torch
from torch import nn

#: learning-rate schedules of a fit (``FitSettings.schedule``)
SCHEDULES = ("cosine", "constant")


@dataclass
class FitSettings:
    """How a module is (re)fitted on the aggregate dataset after every iteration."""

    steps: int = 2000  # gradient steps per fit (when ``epochs`` is None)
    batch_size: int = 64  # minibatch size per step (per ensemble member)
    lr: float = 1e-3  # Adam learning rate
    weight_decay: float = 0.0  # Adam weight decay
    reinit: bool = True  # re-initialise the weights before each fit (fresh ensemble each iteration)
    epochs: float | None = None  # if set: passes over the data per fit, steps = ceil(epochs * n / batch_size)
    schedule: str = "cosine"  # learning rate over the fit: "cosine" (annealed to 0 at the last step) or "constant"
    min_steps: int = 0  # with ``epochs``: at least this many steps (a small D gets enough steps to converge)

    def __post_init__(self) -> None:
        for name in ("steps", "batch_size"):
            if int(getattr(self, name)) <= 0:
                raise ValueError(f"{name} = {getattr(self, name)}: expected a positive integer")
        if self.lr <= 0:
            raise ValueError(f"lr = {self.lr}: expected a positive learning rate")
        if self.epochs is not None and not self.epochs > 0:
            raise ValueError(f"epochs = {self.epochs}: expected a positive number of passes over the data (or null)")
        if int(self.min_steps) < 0:
            raise ValueError(f"min_steps = {self.min_steps}: expected a number of steps >= 0")
        if self.schedule not in SCHEDULES:
            raise ValueError(f"schedule = {self.schedule!r}: expected one of {', '.join(SCHEDULES)}")

    def num_steps(self, n_data: int) -> int:
        """Gradient steps of a fit on ``n_data`` examples."""
        if self.epochs is None:
            return int(self.steps)
        return max(1, int(self.min_steps), math.ceil(self.epochs * n_data / self.batch_size))


def adam(
    params: Iterable[torch.Tensor], settings: FitSettings, steps: int
) -> tuple[torch.optim.Adam, Callable[[], None]]:
    """Adam for a fit of ``steps`` steps and the function to call after each step (the schedule).

    ``cosine`` anneals the learning rate from ``lr`` to 0 at the last step. Measured on the aperture task
    (docs/learner.md): at a constant rate the fit ends wherever the minibatch noise has left it, and on
    a 1.0 cm aperture half of the ensemble members then fail every test episode; annealed, 1 in 20.
    """
    opt = torch.optim.Adam(params, lr=settings.lr, weight_decay=settings.weight_decay, foreach=True)
    if settings.schedule == "constant":
        return opt, lambda: None
    scheduler = torch.optim.lr_scheduler.LambdaLR(
        opt, lambda t: 0.5 * (1.0 + math.cos(math.pi * min(t, steps) / steps))
    )
    return opt, scheduler.step


def member_batches(
    n_data: int, members: int, batch_size: int, generator: torch.Generator, bootstrap: torch.Tensor | None = None
) -> torch.Tensor:
    """Indices ``[members, batch]`` drawn independently per member (from its bootstrap resample if given)."""
    b = min(batch_size, n_data) if bootstrap is None else min(batch_size, bootstrap.shape[1])
    if bootstrap is None:
        return torch.randint(0, n_data, (members, b), generator=generator)
    pick = torch.randint(0, bootstrap.shape[1], (members, b), generator=generator)
    return torch.gather(bootstrap, 1, pick)


def seeded_reset(reset: Callable[[], None], generator: torch.Generator) -> None:
    """Run ``reset`` (a re-initialisation using torch's global RNG) seeded from ``generator``,
    leaving the global RNG as it was: refits are reproducible from the run's own generator."""
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(int(torch.randint(0, 2**31 - 1, (1,), generator=generator)))
        reset()


def minibatch_fit(
    module: nn.Module,
    settings: FitSettings,
    n_data: int,
    generator: torch.Generator,
    loss_of: Callable[[torch.Tensor], torch.Tensor],
) -> list[float]:
    """Adam (with the settings' schedule) on ``loss_of(idx)`` for ``settings.num_steps(n_data)`` minibatches of
    indices drawn with replacement from ``generator``; ``module`` is in train mode meanwhile. Returns the loss
    curve."""
    steps = settings.num_steps(n_data)
    opt, scheduled = adam(module.parameters(), settings, steps)
    b = min(settings.batch_size, n_data)
    losses = []
    module.train()
    for _ in range(steps):
        loss = loss_of(torch.randint(0, n_data, (b,), generator=generator))
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        scheduled()
        losses.append(loss.item())
    module.eval()
    return losses
