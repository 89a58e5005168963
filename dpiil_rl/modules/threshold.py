"""How χ is set: tiny callables chosen by config (``method.threshold``), as imitation's BetaSchedule.

A rule maps the risk values of the training data to a threshold. The paper's protocol flags about
the top 20% of training-data risk as risky (``QuantileThreshold(0.8)``); the sensitivity study fixes χ.
"""

from __future__ import annotations

import torch


class QuantileThreshold:
    """χ = the ``quantile``-quantile of risk over the training data (0.8 ⇒ top 20% count as risky)."""

    def __init__(self, quantile: float = 0.8) -> None:
        q = float(quantile)
        if not 0.0 < q < 1.0:
            raise ValueError(f"method.threshold.quantile = {quantile}: expected a number strictly between 0 and 1")
        self.quantile = q

    def __call__(self, risk: torch.Tensor) -> float:
        values = risk.detach().reshape(-1).double()
        values = values[torch.isfinite(values)]
        if values.numel() == 0:
            raise ValueError("cannot calibrate χ: no finite risk value on the training data")
        return float(torch.quantile(values, self.quantile))

    def __repr__(self) -> str:
        return f"QuantileThreshold(quantile={self.quantile})"


class FixedThreshold:
    """χ fixed by hand (sensitivity study, or a value carried over from another run)."""

    def __init__(self, value: float) -> None:
        v = float(value)
        if not v >= 0.0:
            raise ValueError(f"method.threshold.value = {value}: expected a threshold >= 0")
        self.value = v

    def __call__(self, risk: torch.Tensor) -> float:
        del risk
        return self.value

    def __repr__(self) -> str:
        return f"FixedThreshold(value={self.value})"
