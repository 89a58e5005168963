"""A one-screen summary of a finished run, printed at the end of ``make train``."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from dpiil_rl.records.run_files import read_jsonl


def _fmt(value: Any) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.3f}"
    return str(value)


def print_summary(run_dir: str | Path) -> dict[str, Any]:
    run_dir = Path(run_dir)
    summary = json.loads((run_dir / "summary.json").read_text())
    metrics = read_jsonl(run_dir / "metrics.jsonl")
    cols = [
        "iteration",
        "expert_actions",
        "expert_share",
        "interactive_success",
        "autonomous_success",
        "interventions",
        "collisions",
        "chi",
    ]
    widths = [max(len(c), 9) for c in cols]
    lines = ["  ".join(c.rjust(w) for c, w in zip(cols, widths))]
    for row in metrics:
        lines.append("  ".join(_fmt(row.get(c)).rjust(w) for c, w in zip(cols, widths)))
    print(f"\n== {summary.get('env')} · {summary.get('method')} · seed {summary.get('seed')} ==  run: {run_dir}")
    print("\n".join(lines))
    print(
        f"interactive success {_fmt(summary['interactive_success'])} · autonomous success "
        f"{_fmt(summary['autonomous_success'])} · expert actions {summary['expert_actions']} · interventions "
        f"{summary['interventions']} · collisions {summary['collisions']} · wall time {summary['wall_time_s']:.1f} s"
    )
    if summary.get("expert_share") is not None:
        print(
            f"the expert drove {_fmt(summary['expert_share'])} of the interactive steps and was queried at "
            f"{_fmt(summary.get('query_share'))} of them ({summary.get('expert_queries')} queries)"
        )
    print(f"files: {run_dir}/{{metrics.jsonl, episodes.jsonl, summary.json, plots/, checkpoints/}}\n")
    return summary
