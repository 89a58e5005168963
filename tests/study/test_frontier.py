import math
from types import SimpleNamespace

import pytest

from dpiil_rl.study.frontier import area_under_frontier, frontier_points, interpolate, matched_effort


def _run(method, q, seed, share, success, collisions=0.0):
    cfg = {
        "method": {
            "name": method,
            "threshold": {"quantile": q},
            "frontier": {"key": "method.threshold.quantile", "values": [0.5, 0.8], "label": "q"},
        }
    }
    summary = {
        "expert_share": share,
        "query_share": share,
        "expert_actions": 1000,
        "interactive_success": success,
        "interactive_success_iter_mean": success,
        "collisions": collisions,
        "autonomous_success": 1.0,
    }
    return SimpleNamespace(
        env="aperture",
        method=method,
        seed=seed,
        chi_fixed=None,
        config_data=cfg,
        summary=summary,
        run_name=f"{method}-q{q}",
    )


def _study(offset):
    """Two methods, three seeds, three knob values: ``b`` is ``offset`` better at every share."""
    runs = []
    for seed in range(3):
        for q, share in ((0.5, 0.4), (0.8, 0.2), (0.95, 0.05)):
            base = 0.5 + share + 0.01 * seed
            runs.append(_run("a", q, seed, share, base))
            runs.append(_run("b", q, seed, share + 0.01, base + offset + 0.01))  # a slightly different effort
    return runs


def test_interpolation_is_linear_inside_and_undefined_outside():
    curve = [(0.1, 0.5), (0.3, 0.9)]
    assert interpolate(curve, 0.2) == pytest.approx(0.7)
    assert math.isnan(interpolate(curve, 0.05)) and math.isnan(interpolate(curve, 0.35))
    assert interpolate([(0.1, 0.4), (0.1, 0.6), (0.2, 1.0)], 0.1) == pytest.approx(0.5)  # equal efforts averaged


def test_matched_effort_compares_at_the_same_share_pairing_seeds():
    rows = matched_effort(_study(0.1), levels=(0.2,), reference="b", outcomes=("interactive_success",))
    a = next(r for r in rows if r.method == "a")
    # at 20%: a = 0.5 + 0.2 + 0.01 s; b's curve shifted by +0.01 in share and +0.11 in success → +0.1 at equal share
    assert a.n == 3 and a.pairs == 3
    assert a.diff == pytest.approx(0.1)
    assert a.diff_ci[0] == pytest.approx(0.1) and a.p_value == 0.0 and a.seeds_needed == 2.0


def test_points_average_seeds_and_the_area_covers_the_common_range():
    points = frontier_points(_study(0.0))
    assert {(p.method, p.knob) for p in points} == {(m, q) for m in "ab" for q in (0.5, 0.8, 0.95)}
    p = next(p for p in points if p.method == "a" and p.knob == 0.8)
    assert p.effort["expert_share"] == pytest.approx(0.2) and p.outcome["interactive_success"][0] == pytest.approx(0.71)
    ranges, rows = area_under_frontier(_study(0.1), reference="b")
    assert ranges[("aperture", "a")] == pytest.approx((0.06, 0.4))  # the range a and the reference b both cover
    a = next(r for r in rows if r.method == "a")
    assert a.diff == pytest.approx(0.1) and a.pairs == 3


def test_a_gate_that_only_asks_a_lot_does_not_shrink_the_others_area():
    runs = _study(0.1)
    for seed in range(3):  # "c" only covers 30–50% share
        for q, share in ((0.5, 0.5), (0.8, 0.3)):
            runs.append(_run("c", q, seed, share, 0.9))
    ranges, rows = area_under_frontier(runs, reference="b")
    assert ranges[("aperture", "a")] == pytest.approx((0.06, 0.4))
    assert ranges[("aperture", "c")] == pytest.approx((0.3, 0.41))
    a = next(r for r in rows if r.method == "a")
    assert a.diff == pytest.approx(0.1) and a.effort_range == pytest.approx((0.06, 0.4))
