"""The gate-trace tables, from saved traces: correlations, stages, the would-hand-over share by speed."""

import json
from pathlib import Path

from dpiil_rl.study.study_runs import load_study
from tests.conftest import run_script
from tests.study.synthetic_runs import write_study


def _trace(run_dir: Path, scale: float) -> None:
    """Two episodes whose μ_λ grows with the robot's speed; risk = scale / μ_λ, χ = 1."""
    rows = []
    for e in range(2):
        speed = [float("nan"), 0.001, 0.004, 0.012, 0.02]  # metres per step
        mu = [0.5, 1.0, 2.0, 3.0, 4.0]
        rows.append(
            {
                "episode": e,
                "success": True,
                "length": 5,
                "action_var": [scale] * 5,
                "speed_mu": mu,
                "speed_sigma": [0.1] * 5,
                "risk": [scale / m for m in mu],
                "speed": speed,
                "stage": [0, 0, 1, 1, 2],
                "chi": 1.0,
            }
        )
    (run_dir / "evaluations").mkdir(exist_ok=True)
    (run_dir / "evaluations" / "gate_trace_2ep.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))


def test_the_tables_say_the_precision_reads_the_speed_and_where_the_gate_would_ask(tmp_path):
    """``runs`` may be a list; a run named ``dpiil_ucb-no_velocity_precision`` (method dpiil_ucb, another
    study) is traced and tabulated apart from the plain dpiil_ucb runs."""
    from tests.study.synthetic_runs import write_run

    dirs = write_study(tmp_path / "study")
    variant = write_run(
        tmp_path / "variant", "dpiil_ucb", 0, [1.0], [1.0, 1.0], run_name="dpiil_ucb-no_velocity_precision"
    )
    for d in [*dirs, variant]:
        _trace(d, 2.5)
    out = tmp_path / "trace.md"
    run_script(
        "gate_trace",
        f"runs=[{tmp_path / 'study'},{tmp_path / 'variant'}]",
        "episodes=2",
        "methods=[dpiil_ucb,ensemble_dagger]",
        "stage_names=[reach,grasped,lifted]",
        f"out={out}",
    )
    text = out.read_text()
    seeds = len([r for r in load_study(tmp_path / "study") if r.method == "dpiil_ucb"])
    # μ_λ rises with the speed in every seed: correlation +1; the risk falls with it: −1
    assert f"| dpiil_ucb | {seeds} | {10 * seeds:,} | +1.00" in text and "| -1.00" in text
    # reach: risk 2.5/0.5 = 5 and 2.5/1 = 2.5 → both above χ; lifted: 2.5/4 < χ
    assert f"| dpiil_ucb | reach | {4 * seeds:,} | 0.1 |" in text and "| 100.0% |" in text
    assert f"| dpiil_ucb | lifted | {2 * seeds:,} | 2 | 4 | 0.1 | 2.5 | 0.625 | 0.0% |" in text
    assert "| dpiil_ucb-no_velocity_precision | 1 | 10 |" in text
