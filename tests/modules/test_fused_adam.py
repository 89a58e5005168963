"""The fused Adam step against the elementwise torch calls it replaced, bit for bit."""

from __future__ import annotations

import math
from typing import Any, Sequence

import pytest
import torch

from dpiil_rl.modules import joint_fit
from dpiil_rl.modules.ensemble_actor import EnsembleActor
from dpiil_rl.modules.fitting import FitSettings
from dpiil_rl.modules.fused_adam import foreach_adam_step, fused_adam_step

BETAS, EPS = joint_fit.BETAS, joint_fit.EPS


def foreach_adam(
    params: Sequence[torch.Tensor],
    grads: Sequence[torch.Tensor],
    moments: Sequence[tuple[torch.Tensor, torch.Tensor]],
    step: int,
    rate: torch.Tensor,
    decay: torch.Tensor | None,
) -> None:
    foreach_adam_step(params, grads, moments, step, rate, decay, BETAS, EPS)


# the ring actor's layers (51 → 256 → 256 → 7) and the aperture's (2 → 64 → 64 → 2), weights and biases: vector
# bodies, and scalar tails (a bias of 7 or 2 per member)
SHAPES = {
    "ring": [(5, 51, 256), (5, 256, 256), (5, 256, 7), (5, 1, 256), (5, 1, 256), (5, 1, 7)],
    "aperture_lockstep": [(60, 2, 64), (60, 64, 64), (60, 64, 2), (60, 1, 64), (60, 1, 64), (60, 1, 2)],
}


@pytest.mark.parametrize("shapes", list(SHAPES))
@pytest.mark.parametrize("with_decay", [False, True])
def test_fused_adam_equals_the_foreach_calls_bit_for_bit(shapes: str, with_decay: bool) -> None:
    g = torch.Generator().manual_seed(3)
    sizes = SHAPES[shapes]
    members = sizes[0][0]
    params = [torch.randn(s, generator=g) * 0.1 for s in sizes]
    ref = [p.clone() for p in params]
    moments = [(torch.zeros(s), torch.zeros(s)) for s in sizes]
    ref_moments = [(torch.zeros(s), torch.zeros(s)) for s in sizes]
    rate = torch.rand(members, generator=g) * 3e-3
    decay = (torch.rand(members, generator=g) * 1e-3).reshape(-1, 1, 1) if with_decay else None
    for step in range(1, 31):
        # gradients over many magnitudes, some exactly zero (dead units)
        grads = [torch.randn(s, generator=g) * 10.0 ** float(torch.randint(-8, 1, (1,), generator=g)) for s in sizes]
        grads[1][:, :3] = 0.0
        foreach_adam(ref, grads, ref_moments, step, rate, decay)
        b1, b2 = BETAS
        fused_adam_step(params, grads, moments, rate / (1.0 - b1**step), decay, BETAS, math.sqrt(1.0 - b2**step), EPS)
    for a, b in zip(params, ref):
        assert torch.equal(a, b)
    for (m, v), (rm, rv) in zip(moments, ref_moments):
        assert torch.equal(m, rm) and torch.equal(v, rv)


def test_a_fit_ends_where_the_foreach_adam_ends(monkeypatch: pytest.MonkeyPatch) -> None:
    """A whole actor fit (cosine rate, weight decay) with the fused step and with the reference: the same bits."""
    g = torch.Generator().manual_seed(0)
    obs = torch.rand(300, 3, generator=g) * 2 - 1
    act = torch.tanh(obs[:, :2] * 0.7)
    settings = FitSettings(steps=150, epochs=None, batch_size=32, lr=3e-3, schedule="cosine", weight_decay=1e-4)

    def fit() -> tuple[EnsembleActor, list[float]]:
        actor = EnsembleActor(-torch.ones(3), torch.ones(3), -torch.ones(2), torch.ones(2), 3, (16, 16))
        losses = actor.fit(obs, act, settings, torch.Generator().manual_seed(1))
        return actor, losses

    fused, fused_losses = fit()

    def reference(self: Any, grads: Sequence[torch.Tensor], step: int, rate: torch.Tensor) -> None:
        foreach_adam(self.params, grads, self.moments, step, rate, self.decay)

    monkeypatch.setattr(joint_fit._Stack, "adam", reference)
    ref, ref_losses = fit()
    assert fused_losses == ref_losses
    for a, b in zip(fused.state_dict().values(), ref.state_dict().values()):
        assert torch.equal(a, b)


def test_fused_adam_refuses_a_tensor_it_cannot_update_in_place() -> None:
    p = torch.zeros(2, 3, dtype=torch.float64)
    with pytest.raises(ValueError, match="contiguous float32"):
        fused_adam_step([p], [p.clone()], [(p.clone(), p.clone())], torch.ones(2), None, BETAS, 1.0, EPS)
