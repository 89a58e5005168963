"""The headline tables of the README and the results pages, recomputed from a study's committed records.

``headline_table(runs)`` renders one markdown table per study (one row per method); the README and each
``docs/results/<study>/README.md`` hold it between ``<!-- headline:<study> -->`` and ``<!-- /headline -->``
(``collapse_table``: ``<!-- collapses:<study> -->`` ... ``<!-- /collapses -->``; ``frontier_table``, where a
method's matched-effort advantage holds: ``<!-- frontier:<study> -->`` ... ``<!-- /frontier -->``),
and ``make headlines`` (or a test) recomputes every such block from ``docs/results/<study>``: a number in
a headline table is always what the records give.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Sequence

from dpiil_rl.study.collapse import count_collapses, total
from dpiil_rl.study.frontier import area_under_frontier, matched_effort
from dpiil_rl.study.frontier_report import robustness_table
from dpiil_rl.study.frontier_robustness import verdicts
from dpiil_rl.study.study_runs import StudyRun, load_study, method_order
from dpiil_rl.study.study_stats import MeanStd, main_runs, method_stats

MARK = re.compile(
    r"<!-- (?P<kind>headline|collapses|frontier):(?P<study>[\w./-]+) -->\n(?P<body>.*?)<!-- /(?P=kind) -->", re.S
)


def _pct(v: MeanStd | None, interval: bool = False) -> str:
    if v is None:
        return "–"
    text = f"{100 * v.mean:.1f}" + ("" if math.isnan(v.std) else f" ± {100 * v.std:.1f}") + "%"
    if interval and not math.isnan(v.ci_low):
        text += f" [{100 * v.ci_low:.1f}, {100 * v.ci_high:.1f}]"
    return text


def _num(v: MeanStd | None, digits: int = 0) -> str:
    if v is None:
        return "–"
    return f"{v.mean:,.{digits}f}" + ("" if math.isnan(v.std) else f" ± {v.std:,.{digits}f}")


def headline_table(runs: Sequence[StudyRun]) -> str:
    """Method | seeds | interactive success [95% CI] | per iteration | autonomous (final) | expert share |
    expert queries | collisions; one block per env when the study has several."""
    stats = method_stats(main_runs(runs))
    envs = sorted({s.env for s in stats})
    lines = []
    for env in envs:
        if len(envs) > 1:
            lines += [f"*{env}*", ""]
        lines += [
            "| method | seeds | interactive success [95% CI] | per iteration | autonomous (final) "
            "| expert share | expert queries | collisions |",
            "|---|---|---|---|---|---|---|---|",
        ]
        for s in (s for s in stats if s.env == env):
            v = s.values
            lines.append(
                f"| {s.method} | {len(s.seeds)} | {_pct(v['interactive_success'], True)} "
                f"| {_pct(v['interactive_success_iter_mean'])} "
                f"| {_pct(v['autonomous_success'], True)} | {_pct(v['expert_share'])} | {_num(v['expert_queries'])} "
                f"| {_num(v['collisions'], 1)} |"
            )
        lines.append("")
    return "\n".join(lines)


def collapse_table(runs: Sequence[StudyRun]) -> str:
    """Env | method | runs | collapsed evaluations | runs that collapsed; a total line (:mod:`.collapse`)."""
    counts = count_collapses(((r.env, r.run_name), f"seed_{r.seed}", r.episodes) for r in main_runs(runs))
    lines = ["| task | method | runs | collapsed evaluations | runs with a collapse |", "|---|---|---|---|---|"]
    for env in sorted({e for e, _ in counts}):
        for method in method_order(m for e, m in counts if e == env):
            c = counts[(env, method)]
            lines.append(
                f"| {env} | {method} | {c.runs} | {c.collapses} of {c.evaluations} | {len(c.collapsed_runs)} |"
            )
    t = total(counts.values())
    lines += [
        f"| all | | {t.runs} | {t.collapses} of {t.evaluations} ({100 * (t.rate or 0.0):.2f}%) "
        f"| {len(t.collapsed_runs)} |",
        "",
    ]
    return "\n".join(lines)


def frontier_table(runs: Sequence[StudyRun], reference: str = "dpiil_ucb") -> str:
    """Per geometry and method: the reference's paired gap in interactive success at matched expert share and
    over the area under the frontier, Holm-adjusted, and the verdict (:mod:`.frontier_robustness`)."""
    _, auf = area_under_frontier(runs, reference=reference)
    judged = verdicts(matched_effort(runs, reference=reference), auf, reference)
    return "\n".join([*robustness_table(judged), ""]) if judged else "No frontier runs to compare yet.\n"


def refresh_headlines(
    path: str | Path, results_root: str | Path, loaded: dict[Path, list[StudyRun]] | None = None
) -> tuple[str, list[str]]:
    """``path``'s text with every headline block recomputed from ``results_root/<study>``; the studies found.

    ``loaded`` (study folder → its runs) lets several pages that show the same study read its records once.
    """
    text = Path(path).read_text()
    studies: list[str] = []
    loaded = {} if loaded is None else loaded

    def render(match: re.Match[str]) -> str:
        kind, study = match.group("kind"), match.group("study")
        studies.append(study)
        root = (Path(results_root) / study).resolve()
        if root not in loaded:
            loaded[root] = load_study(root)
        runs = loaded[root]
        body = {"headline": headline_table, "collapses": collapse_table, "frontier": frontier_table}[kind](runs)
        return f"<!-- {kind}:{study} -->\n{body}<!-- /{kind} -->"

    return MARK.sub(render, text), studies
