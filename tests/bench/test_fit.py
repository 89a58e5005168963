"""The fit suite of ``make bench`` runs and times both Adam steps on both shapes."""

from __future__ import annotations

from dpiil_rl.bench.fit import ADAM_SHAPES, adam_step_cost


def test_adam_step_cost_times_both_ways_on_every_shape() -> None:
    out = adam_step_cost(steps=2, rounds=2)
    assert set(out) == set(ADAM_SHAPES)
    for row in out.values():
        assert row["foreach_ms"] > 0 and row["fused_ms"] > 0
        assert abs(row["ratio"] - row["foreach_ms"] / row["fused_ms"]) < 0.05  # the ms are rounded to 3 digits
