"""Adam's update in two compiled passes over each parameter, with the bits of the elementwise torch calls.

The joint fit's Adam (:meth:`~dpiil_rl.modules.joint_fit._Stack.adam`) was ten foreach calls per step, each a
pass over every parameter in memory: ≈ 1.1 ms of a ≈ 3.3 ms step of the ring's 256-wide actor (one thread, this
machine). This module computes the same update in two numba loops and torch's square root (≈ 0.7 ms), with the
rounding of each of the replaced kernels on CPU (measured with torch 2.13):

- ``m ← fma(g, 1 − β₁, m·β₁)`` — ``add_(g, alpha=1 − β₁)`` is a fused multiply-add, in its vector body and in its
  scalar tail;
- ``v ← fma((1 − β₂)·g, g, v·β₂)`` — ``addcmul_(g, g, value=1 − β₂)`` multiplies the value and ``g`` first, then fuses;
- ``d ← √v / c₂ + ε`` with a true division (not a product with ``1 / c₂``), √v by torch itself (its vectorised
  square root is not the correctly rounded one);
- ``p ← p − (m / d)·s`` with ``s`` the member's learning rate over ``c₁``; weight decay as ``g + p·λ``, two roundings.

The scalars are those torch uses: Python floats cast to float32. :func:`foreach_adam_step` keeps the replaced calls
as the reference: ``tests/modules/test_fused_adam.py`` holds the update to them bit for bit on the actor shapes
(vector bodies and scalar tails), with and without weight decay, so fits and the records they make do not change.
"""

from __future__ import annotations

import math
from typing import Any, Callable, Sequence

import numpy as np
import torch
from numba import njit
from numba.extending import intrinsic


def _intrinsic(definition: Callable[..., object]) -> Callable[..., Any]:
    """numba's ``intrinsic``, typed as compiled code calls the result (numba's stub keeps the typing context)."""
    return intrinsic(definition)


@_intrinsic
def _fma(typingctx, a, b, c):  # type: ignore[no-untyped-def]
    """``a·b + c`` rounded once (LLVM's ``fma``), as torch's CPU kernels compute ``add`` with ``alpha``."""
    signature = a(a, b, c)

    def codegen(context, builder, sig, args):  # type: ignore[no-untyped-def]
        return builder.fma(*args)

    return signature, codegen


@njit(cache=True, nogil=True, error_model="numpy", boundscheck=False)
def _moments(g, p, m, v, decay, use_decay, b1, one_minus_b1, b2, one_minus_b2):  # type: ignore[no-untyped-def]
    """Adam's moments of ``p`` (flat, ``len(decay)`` members one after the other) updated in place from its
    gradient ``g``."""
    width = p.shape[0] // decay.shape[0]
    if use_decay:
        for i in range(decay.shape[0]):  # a member's slice at a time: the inner loop vectorises
            lam = decay[i]
            a, z = i * width, (i + 1) * width
            gi, pi, mi, vi = g[a:z], p[a:z], m[a:z], v[a:z]
            for j in range(width):
                grad = gi[j] + pi[j] * lam
                mi[j] = _fma(grad, one_minus_b1, mi[j] * b1)
                vi[j] = _fma(one_minus_b2 * grad, grad, vi[j] * b2)
    else:
        for j in range(p.shape[0]):
            grad = g[j]
            m[j] = _fma(grad, one_minus_b1, m[j] * b1)
            v[j] = _fma(one_minus_b2 * grad, grad, v[j] * b2)


@njit(cache=True, nogil=True, error_model="numpy", boundscheck=False)
def _move(p, m, root_v, scaled, c2, eps):  # type: ignore[no-untyped-def]
    """``p ← p − (m / (√v / c₂ + ε))·s`` in place, ``root_v`` = √v computed by torch (its vectorised square root
    is not the correctly rounded one: one ulp off in about 1% of elements on AVX512, so it is torch's call)."""
    width = p.shape[0] // scaled.shape[0]
    for i in range(scaled.shape[0]):  # a member's slice at a time: the inner loop vectorises
        s = scaled[i]
        a, z = i * width, (i + 1) * width
        pi, mi, ri = p[a:z], m[a:z], root_v[a:z]
        for j in range(width):
            pi[j] = pi[j] - (mi[j] / (ri[j] / c2 + eps)) * s


def _rows(t: torch.Tensor) -> np.ndarray:
    """``t`` ``[M, ...]`` as a flat float32 numpy view of its own memory (written in place), members in order."""
    if t.dtype != torch.float32 or not t.is_contiguous():
        raise ValueError(
            f"fused Adam: expected contiguous float32 tensors, got {t.dtype}, contiguous={t.is_contiguous()}"
        )
    return t.detach().numpy().reshape(-1)


def fused_adam_step(
    params: Sequence[torch.Tensor],
    grads: Sequence[torch.Tensor],
    moments: Sequence[tuple[torch.Tensor, torch.Tensor]],
    scaled: torch.Tensor,
    decay: torch.Tensor | None,
    betas: tuple[float, float],
    bias_correction2: float,
    eps: float,
) -> None:
    """Adam step ``step`` on every ``params[k]`` ``[M, ...]`` in place: member ``i`` moves by its own rate
    ``scaled[i]`` (learning rate / (1 − β₁ᵗ)); ``decay`` ``[M]`` is each member's L2 weight decay (None: none);
    ``bias_correction2`` is √(1 − β₂ᵗ)."""
    b1, b2 = betas
    f = np.float32
    rate = np.ascontiguousarray(scaled.detach().reshape(-1).numpy(), dtype=np.float32)
    lam = (
        np.zeros_like(rate)
        if decay is None
        else np.ascontiguousarray(decay.detach().reshape(-1).numpy(), dtype=np.float32)
    )
    for p, g, (m, v) in zip(params, grads, moments):
        rows = _rows(p)
        moment, second = _rows(m), _rows(v)
        grad = _rows(g.contiguous())
        _moments(grad, rows, moment, second, lam, decay is not None, f(b1), f(1.0 - b1), f(b2), f(1.0 - b2))
        _move(rows, moment, _rows(torch.sqrt(v)), rate, f(bias_correction2), f(eps))


def foreach_adam_step(
    params: Sequence[torch.Tensor],
    grads: Sequence[torch.Tensor],
    moments: Sequence[tuple[torch.Tensor, torch.Tensor]],
    step: int,
    rate: torch.Tensor,
    decay: torch.Tensor | None,
    betas: tuple[float, float],
    eps: float,
) -> None:
    """The same step as the joint fit computed it before: torch's foreach calls, a pass over memory each (the
    reference of the tests and of ``make bench``'s fit suite). ``rate`` ``[M]``, ``decay`` ``[M, 1, 1]`` or None."""
    b1, b2 = betas
    c1, c2 = 1.0 - b1**step, math.sqrt(1.0 - b2**step)
    scaled = (rate / c1).reshape(-1, 1, 1)
    m = [x for x, _ in moments]
    v = [y for _, y in moments]
    ops: Any = torch  # the foreach kernels: public since torch 2.0 but not exported in its type stubs
    with torch.no_grad():
        g = grads if decay is None else ops._foreach_add(grads, ops._foreach_mul(params, [decay] * len(params)))
        ops._foreach_mul_(m, b1)
        ops._foreach_add_(m, g, alpha=1.0 - b1)
        ops._foreach_mul_(v, b2)
        ops._foreach_addcmul_(v, g, g, value=1.0 - b2)
        denom = ops._foreach_sqrt(v)
        ops._foreach_div_(denom, c2)
        ops._foreach_add_(denom, eps)
        update = ops._foreach_div(m, denom)
        ops._foreach_mul_(update, [scaled] * len(update))
        ops._foreach_sub_(params, update)
