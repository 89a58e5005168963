"""Aggregate finished runs (their ``summary.json`` files) into a mean ± std table per env and method."""

from __future__ import annotations

import csv
import json
import statistics
from collections import defaultdict
from pathlib import Path
from typing import Any

FIELDS = ("interactive_success", "autonomous_success", "expert_actions", "interventions", "collisions", "wall_time_s")


def collect_summaries(root: str | Path) -> list[dict[str, Any]]:
    root = Path(root)
    if not root.is_dir():
        raise FileNotFoundError(f"runs = {str(root)!r}: no such directory (expected a directory of run directories)")
    return [json.loads(p.read_text()) for p in sorted(root.rglob("summary.json"))]


def _mean_std(values: list[float]) -> tuple[float, float]:
    return statistics.fmean(values), (statistics.stdev(values) if len(values) > 1 else 0.0)


def aggregate(summaries: list[dict[str, Any]]) -> list[dict[str, Any]]:
    groups: dict[tuple[str, str], list[dict[str, Any]]] = defaultdict(list)
    for s in summaries:
        groups[(s["env"], s["method"])].append(s)
    rows = []
    for (env, method), runs in sorted(groups.items()):
        row: dict[str, Any] = {"env": env, "method": method, "seeds": sorted(r["seed"] for r in runs)}
        for field in FIELDS:
            values = [float(r[field]) for r in runs if r.get(field) is not None]
            row[field] = _mean_std(values) if values else None
        rows.append(row)
    return rows


def _fmt(value: tuple[float, float] | None, percent: bool) -> str:
    if value is None:
        return "-"
    m, s = value
    return f"{100 * m:.1f} ± {100 * s:.1f}%" if percent else f"{m:.1f} ± {s:.1f}"


def write_tables(rows: list[dict[str, Any]], out_dir: str | Path) -> tuple[Path, Path]:
    out_dir = Path(out_dir)
    header = ["env", "method", "seeds", "interactive success", "autonomous success", "expert actions",
              "interventions", "collisions (interactive)", "wall time (s)"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for r in rows:
        cells = [r["env"], r["method"], str(len(r["seeds"])), _fmt(r["interactive_success"], True),
                 _fmt(r["autonomous_success"], True)] + [_fmt(r[f], False) for f in FIELDS[2:]]
        lines.append("| " + " | ".join(cells) + " |")
    md = out_dir / "results.md"
    md.write_text("\n".join(lines) + "\n")
    csv_path = out_dir / "results.csv"
    with csv_path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["env", "method", "n_seeds"] + [f"{k}_{s}" for k in FIELDS for s in ("mean", "std")])
        for r in rows:
            w.writerow([r["env"], r["method"], len(r["seeds"])] + [x for k in FIELDS for x in (r[k] or ("", ""))])
    return md, csv_path
