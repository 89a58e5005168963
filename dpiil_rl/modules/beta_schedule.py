"""DAgger's mixing schedules ``β_k``: the probability that the expert's action is executed at a step of
iteration ``k`` (Ross et al. 2011, section 3; imitation's ``BetaSchedule``). Tiny callables chosen by
config (``method.beta_schedule``), as the threshold rules.

Iteration 0 is the initial demonstrations, Ross et al.'s ``π_1 = π*`` (``β_1 = 1``); the schedules
give ``β`` for the interactive iterations ``k = 1..K`` (Ross et al.'s ``i = k + 1``).
"""

from __future__ import annotations


class ExponentialBeta:
    """``β_k = p^k`` (Ross et al.'s ``β_i = p^{i−1}``); ``p = 0`` is their "β_1 = 1, then 0", pure DAgger."""

    def __init__(self, p: float = 0.5) -> None:
        if not 0.0 <= float(p) <= 1.0:
            raise ValueError(f"method.beta_schedule.p = {p}: expected a decay in [0, 1]")
        self.p = float(p)

    def __call__(self, iteration: int) -> float:
        return 1.0 if iteration <= 0 else self.p ** int(iteration)

    def __repr__(self) -> str:
        return f"ExponentialBeta(p={self.p})"


class LinearBeta:
    """``β_k = max(0, 1 − k / rampdown)`` (imitation's ``LinearBetaSchedule``)."""

    def __init__(self, rampdown: int = 5) -> None:
        if int(rampdown) < 1:
            raise ValueError(f"method.beta_schedule.rampdown = {rampdown}: expected a number of iterations >= 1")
        self.rampdown = int(rampdown)

    def __call__(self, iteration: int) -> float:
        return min(1.0, max(0.0, 1.0 - int(iteration) / self.rampdown))

    def __repr__(self) -> str:
        return f"LinearBeta(rampdown={self.rampdown})"


class ConstantBeta:
    """The same ``β`` at every interactive iteration."""

    def __init__(self, beta: float = 0.2) -> None:
        if not 0.0 <= float(beta) <= 1.0:
            raise ValueError(f"method.beta_schedule.beta = {beta}: expected a probability in [0, 1]")
        self.beta = float(beta)

    def __call__(self, iteration: int) -> float:
        return 1.0 if iteration <= 0 else self.beta

    def __repr__(self) -> str:
        return f"ConstantBeta(beta={self.beta})"
