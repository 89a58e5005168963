"""The cost of one actor refit: the learner's fit rule now against the rule it replaced.

An ensemble of 5 64-64 members (the aperture task's actor) is fitted on D of 390 pairs (the 3 demos) and
of 1,300 pairs (D after the last iteration), single-threaded, best CPU time of 3 fits:

- ``constant_1e-3``: the old rule, a constant learning rate 1e-3 for 100 epochs;
- ``cosine_3e-3_min1000``: the rule of ``configs/modules/aperture.yaml``: cosine-annealed from 3e-3, 100
  epochs but at least 1,000 steps (docs/learner.md).

:func:`adam_step_cost` times one Adam step of the fit loop on the ring actor's parameters (5 members,
51-256-256-7) and on ten aperture runs' actors side by side (60 members, 2-64-64-2): the foreach calls the loop
used before against the fused step it uses now (:mod:`dpiil_rl.modules.fused_adam`, the same bits), in
alternating rounds, single-threaded.
"""

from __future__ import annotations

import math
import time

import torch

from dpiil_rl.modules.ensemble_actor import EnsembleActor
from dpiil_rl.modules.fitting import FitSettings
from dpiil_rl.modules.fused_adam import foreach_adam_step, fused_adam_step
from dpiil_rl.modules.joint_fit import BETAS, EPS

RULES = {
    "constant_1e-3": FitSettings(epochs=100, batch_size=64, lr=1e-3, schedule="constant", min_steps=0),
    "cosine_3e-3_min1000": FitSettings(epochs=100, batch_size=64, lr=3e-3, schedule="cosine", min_steps=1000),
}


def fit_cost(sizes: tuple[int, ...] = (390, 1300), repeats: int = 3) -> dict:
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        out: dict = {}
        for n in sizes:
            g = torch.Generator().manual_seed(0)
            obs = torch.rand(n, 2, generator=g) * 2 - 1
            act = torch.tanh(obs @ torch.tensor([[0.5, -0.3], [0.2, 0.8]]))
            actor = EnsembleActor(-torch.ones(2), torch.ones(2), -torch.ones(2), torch.ones(2), 5, (64, 64))
            for name, rule in RULES.items():
                times = []
                for r in range(repeats):
                    t0 = time.process_time()
                    actor.fit(obs, act, rule, torch.Generator().manual_seed(r))
                    times.append(time.process_time() - t0)
                out[f"{name}@{n}"] = {"steps": rule.num_steps(n), "cpu_s": round(min(times), 3)}
        return out
    finally:
        torch.set_num_threads(threads)


ADAM_SHAPES = {
    "ring_actor": ((5, 51, 256), (5, 256, 256), (5, 256, 7), (5, 1, 256), (5, 1, 256), (5, 1, 7)),
    "aperture_10_runs": ((60, 2, 64), (60, 64, 64), (60, 64, 2), (60, 1, 64), (60, 1, 64), (60, 1, 2)),
}


def adam_step_cost(steps: int = 300, rounds: int = 3) -> dict:
    """CPU milliseconds per Adam step, foreach calls against the fused step (best of ``rounds`` alternating
    rounds), and their ratio."""
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        out: dict = {}
        for name, shapes in ADAM_SHAPES.items():
            g = torch.Generator().manual_seed(0)
            params = [torch.randn(s, generator=g) * 0.1 for s in shapes]
            grads = [torch.randn(s, generator=g) * 1e-3 for s in shapes]
            moments = [(torch.zeros(s), torch.zeros(s)) for s in shapes]
            rate = torch.full((shapes[0][0],), 1e-3)
            best = {"foreach": math.inf, "fused": math.inf}
            fused_adam_step(params, grads, moments, rate, None, BETAS, 1.0, EPS)  # compiled (or loaded) before timing
            for r in range(rounds):
                for way in ("foreach", "fused") if r % 2 == 0 else ("fused", "foreach"):
                    t0 = time.process_time()
                    for step in range(1, steps + 1):
                        if way == "foreach":
                            foreach_adam_step(params, grads, moments, step, rate, None, BETAS, EPS)
                        else:
                            b1, b2 = BETAS
                            c2 = math.sqrt(1.0 - b2**step)
                            fused_adam_step(params, grads, moments, rate / (1.0 - b1**step), None, BETAS, c2, EPS)
                    best[way] = min(best[way], (time.process_time() - t0) / steps * 1e3)
            out[name] = {
                "foreach_ms": round(best["foreach"], 3),
                "fused_ms": round(best["fused"], 3),
                "ratio": round(best["foreach"] / best["fused"], 2),
            }
        return out
    finally:
        torch.set_num_threads(threads)
