"""The cost of one actor refit: the learner's fit rule now against the rule it replaced.

An ensemble of 5 64-64 members (the aperture task's actor) is fitted on D of 390 pairs (the 3 demos) and
of 1,300 pairs (D after the last iteration), single-threaded, best CPU time of 3 fits:

- ``constant_1e-3``: the old rule, a constant learning rate 1e-3 for 100 epochs;
- ``cosine_3e-3_min1000``: the rule of ``configs/modules/aperture.yaml``: cosine-annealed from 3e-3, 100
  epochs but at least 1,000 steps (docs/learner.md).
"""

from __future__ import annotations

import time

import torch

from dpiil_rl.modules.ensemble_actor import EnsembleActor
from dpiil_rl.modules.fitting import FitSettings

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
