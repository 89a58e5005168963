import math

import pytest

from dpiil_rl.study.frontier import area_under_frontier, matched_effort
from dpiil_rl.study.frontier_robustness import holm, verdicts
from dpiil_rl.study.headline import frontier_table
from tests.study.test_frontier import _run


def test_holm_steps_down_and_keeps_the_order():
    # sorted 0.01, 0.03, 0.04, 0.5 (m = 4): 0.04, 0.09, max(0.09, 0.08), 0.5; nan is not a test
    assert holm([0.01, 0.04, 0.03, math.nan, 0.5]) == pytest.approx([0.04, 0.09, 0.09, math.nan, 0.5], nan_ok=True)
    assert holm([0.6, 0.7]) == [1.0, 1.0]  # capped at 1
    assert holm([]) == []


def _geometry(env, gap, noise, ceiling=False):
    """Methods ``ref`` and ``other`` over 3 knob values and 6 seeds on ``env``: ``ref`` better by ``gap``,
    seed-to-seed noise of the gap ``noise`` (alternating sign); ``ceiling``: both at 100%."""
    runs = []
    for seed in range(6):
        jitter = noise * (1 if seed % 2 else -1)
        for q, share in ((0.5, 0.4), (0.8, 0.2), (0.95, 0.05)):
            base = 1.0 if ceiling else 0.6 + 0.5 * share
            for method, value in (("ref", base if ceiling else base + gap + jitter), ("other", base)):
                run = _run(method, q, seed, share, value)
                run.env = env
                runs.append(run)
    return runs


def _verdicts(runs):
    matched = matched_effort(runs, reference="ref", outcomes=("interactive_success",))
    _, auf = area_under_frontier(runs, reference="ref")
    return {v.env: v for v in verdicts(matched, auf, reference="ref")}


def test_a_consistent_gap_holds_a_noisy_one_is_not_resolved_and_the_ceiling_is_named():
    runs = _geometry("wide", 0.0, 0.0, ceiling=True) + _geometry("clear", 0.05, 0.001) + _geometry("noisy", 0.01, 0.05)
    judged = _verdicts(runs)
    assert judged["clear"].verdict == "holds"
    assert judged["noisy"].verdict == "not resolved"
    assert judged["wide"].verdict == "not resolved (both at the ceiling)"
    v = judged["clear"]
    assert v.family == 3 * 4  # 3 geometries x (3 levels + AUF); at the ceiling the zero gaps have p = 1 and count
    assert [c.level for c in v.gaps][:3] == [0.1, 0.2, 0.3] and math.isnan(v.gaps[-1].level)
    assert judged["noisy"].seeds_auf_family > judged["noisy"].seeds_auf > 6  # more seeds at α/m than at α


def test_the_reference_worse_is_reversed():
    judged = _verdicts(_geometry("clear", -0.05, 0.001))
    assert judged["clear"].verdict == "reversed"


def test_the_headline_block_shows_one_verdict_per_geometry():
    runs = _geometry("clear", 0.05, 0.001) + _geometry("noisy", 0.01, 0.05)
    lines = frontier_table(runs, reference="ref").splitlines()
    rows = [line for line in lines if line.startswith("| clear") or line.startswith("| noisy")]
    assert len(rows) == 2
    assert rows[0].endswith("**holds** |") and rows[1].endswith("**not resolved** |")
    assert "+5.0 pts" in rows[0]  # the gap in points at every matched share


def test_the_report_section_draws_every_geometry_and_states_the_verdicts(tmp_path):
    from dpiil_rl.study.frontier_report import frontier_section

    runs = _geometry("clear", 0.05, 0.001) + _geometry("noisy", 0.01, 0.05)
    files, data = frontier_section(runs, tmp_path, ["clear", "noisy"], reference="ref")
    assert {"frontier_overview.png", "frontier_clear.png", "frontier_noisy.png", "frontier.md"} <= set(files)
    assert all(p.stat().st_size > 10_000 for name, p in files.items() if name.endswith(".png"))
    text = (tmp_path / "frontier.md").read_text()
    assert "## Where ref's advantage at matched effort holds" in text and "**holds**" in text
    assert [(v["env"], v["verdict"]) for v in data["robustness"]] == [("clear", "holds"), ("noisy", "not resolved")]
