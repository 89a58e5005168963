"""The study report: results table beside the paper's numbers, significance tests, χ sensitivity and the
paper's Fig. 3 panels, from one or more directories of finished runs.

``write_study_report(["runs/paper"], "runs/paper/report")`` writes ``results.md``/``results.csv``,
``stats.md``/``stats.json`` and ``fig3c_interactive.png``, ``fig3c_autonomous.png``, ``fig3a_maps.png``,
``fig3d_chi_sensitivity.png`` (when fixed-χ runs exist), ``stages.png`` (multi-stage tasks: how far the
episodes got, and ``results.md`` says where the person was asked to act, by stage), and ``index.html``
(+ ``runs/``): the same report as a self-contained web page with one page per run
(:mod:`dpiil_rl.study.html_report`). With several envs every figure name gets the env as a suffix
(``fig3c_interactive_ring.png``). Every number is recomputed from ``episodes.jsonl``.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import asdict
from pathlib import Path
from typing import Any, Sequence

from omegaconf import OmegaConf

from dpiil_rl.records.run_files import clean_json
from dpiil_rl.study.collapse import HIGH, LOW, count_collapses, total
from dpiil_rl.study.frontier_report import frontier_section
from dpiil_rl.study.gate_stages import gate_stages_section
from dpiil_rl.study.html_report import write_html_report
from dpiil_rl.study.machines import code_note, machines_note
from dpiil_rl.study.stage_bars import stage_bars
from dpiil_rl.study.stage_table import stage_counts, stage_order, stages_section
from dpiil_rl.study.study_figures import autonomous_vs_expert_actions, chi_sensitivity, interactive_boxplot
from dpiil_rl.study.study_maps import plot_study_maps
from dpiil_rl.study.study_runs import StudyRun, dataset_mismatches, load_study
from dpiil_rl.study.study_stats import (
    FIELDS,
    TESTED_FIELDS,
    ChiFit,
    ChiPoint,
    MeanStd,
    MethodStats,
    WelchTest,
    by_env_method,
    chi_correlations,
    chi_points,
    main_runs,
    method_stats,
    significance_stars,
    values_of,
    welch_tests,
)

#: where ``<env>.yaml`` with the paper's numbers lives (a missing file means no paper column)
PAPER_REFERENCE_DIR = Path(__file__).resolve().parents[1] / "configs" / "paper_reference"
PERCENT_FIELDS = ("interactive_success", "autonomous_success")
#: fields shown in percent (success rates and shares) and those shown with their bootstrap interval
SHARE_FIELDS = ("interactive_success", "interactive_success_iter_mean", "autonomous_success", "expert_share")
CI_FIELDS = ("interactive_success", "interactive_success_iter_mean", "autonomous_success")
#: what a paper reference file may give per method: the success rates (%) and, for Table I, the interventions
PAPER_FIELDS = PERCENT_FIELDS + ("interventions",)
LABELS = {
    "interactive_success": "interactive success",
    "interactive_success_iter_mean": "interactive success, mean over iterations",
    "autonomous_success": "autonomous success (final)",
    "expert_actions": "expert actions",
    "expert_share": "expert share of interactive steps",
    "expert_queries": "expert queries",
    "interventions": "interventions",
    "collisions": "collisions (interactive)",
}
CONVENTIONS = (
    "std: sample std over seeds (n/a with one seed). Welch t-test, two-sided, reference vs each method; "
    "when both groups have zero variance the test is undefined: equal means → p = 1, different means → p = 0 "
    "(the limit), each with a note; fewer than 2 seeds in a group → no test. Marks: *** p < 5e-4, ** p < 5e-3, "
    "* p < 5e-2, n.s. otherwise. r²: squared Pearson correlation of log10(χ) with success over the fixed-χ runs, "
    "every seed one point; constant input → n/a."
)


def load_paper_reference(env: str, paper_dir: str | Path | None = None) -> dict[str, dict[str, float | None]] | None:
    """``{field: {method: percent or None}}`` from ``<paper_dir>/<env>.yaml``, or None if there is no file."""
    path = Path(paper_dir or PAPER_REFERENCE_DIR) / f"{env}.yaml"
    if not path.exists():
        return None
    data = OmegaConf.to_container(OmegaConf.load(path), resolve=True)
    assert isinstance(data, dict)
    return {
        f: {str(m): (None if v is None else float(v)) for m, v in (data.get(f) or {}).items()} for f in PAPER_FIELDS
    }


def _fmt(value: MeanStd | None, percent: bool, interval: bool = False) -> str:
    """``mean ± std`` (``[low, high]``: the bootstrap 95% interval of the mean, with ``interval``)."""
    if value is None:
        return "–"
    scale, unit = (100.0, "%") if percent else (1.0, "")
    if math.isnan(value.std):
        return f"{scale * value.mean:.1f}{unit} (n=1)"
    text = f"{scale * value.mean:.1f} ± {scale * value.std:.1f}{unit}"
    if interval and not math.isnan(value.ci_low):
        text += f" [{scale * value.ci_low:.1f}, {scale * value.ci_high:.1f}]"
    return text


def _num(x: float, digits: int = 3) -> str:
    return "n/a" if x is None or math.isnan(x) else f"{x:.{digits}g}"


def _paper(paper: dict[str, dict[str, float | None]] | None, field: str, method: str) -> float | None:
    return None if paper is None else paper.get(field, {}).get(method)


def _table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    return ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)] + ["| " + " | ".join(r) + " |" for r in rows]


def results_markdown(
    stats: Sequence[MethodStats],
    points: Sequence[ChiPoint],
    papers: dict[str, dict[str, dict[str, float | None]] | None],
    notes: Sequence[str],
    stages: str = "",
    collapses: str = "",
) -> str:
    """``results.md``: the table beside the paper's numbers, ``stages`` (how far episodes got, when the task
    has stages), the χ-sensitivity table and the notes."""
    # the paper's interventions column appears when some paper reference gives them (Table I)
    paper_fields = list(PERCENT_FIELDS) + (
        ["interventions"]
        if any(any(v is not None for v in (p or {}).get("interventions", {}).values()) for p in papers.values())
        else []
    )
    header = (
        ["env", "method", "seeds"]
        + [LABELS[f] for f in FIELDS]
        + [f"paper {LABELS[f].split(' (')[0].replace(' success', '')}" for f in paper_fields]
    )
    rows = []
    for s in stats:
        paper = papers.get(s.env)
        rows.append(
            [s.env, s.method, str(len(s.seeds))]
            + [_fmt(s.values[f], f in SHARE_FIELDS, f in CI_FIELDS) for f in FIELDS]
            + [
                (
                    "–"
                    if _paper(paper, f, s.method) is None
                    else f"{_paper(paper, f, s.method):g}{'%' if f in PERCENT_FIELDS else ''}"
                )
                for f in paper_fields
            ]
        )
    lines = [
        "# Study results",
        "",
        "Mean ± sample std over seeds [bootstrap 95% interval of the mean], recomputed from every "
        "run's `episodes.jsonl`; calibrated-χ runs only. Interactive success pooled over all interactive episodes, and "
        "as the mean of each iteration's rate. Effort: expert actions are the labels in D (demos included), the expert "
        "share is the fraction of interactive steps the expert drove, expert queries count every interactive step at "
        "which the expert had to act or judge (monitoring included). Paper columns: "
        "`configs/paper_reference/<env>.yaml` (– = no number).",
        "",
    ]
    lines += _table(header, rows)
    if collapses:
        lines += ["", collapses.rstrip("\n")]
    if stages:
        lines += ["", stages.rstrip("\n")]
    if points:
        lines += ["", "## χ sensitivity (fixed χ)", ""]
        lines += _table(
            ["env", "method", "χ", "seeds", "interactive success", "autonomous success (final)"],
            [
                [
                    p.env,
                    p.method,
                    f"{p.chi:.2e}",
                    str(len(p.seeds)),
                    _fmt(p.values["interactive_success"], True),
                    _fmt(p.values["autonomous_success"], True),
                ]
                for p in points
            ],
        )
    if notes:
        lines += ["", "Notes:", ""] + [f"- {n}" for n in notes]
    return "\n".join(lines) + "\n"


def write_results_csv(stats: Sequence[MethodStats], papers: dict[str, Any], path: Path) -> Path:
    """One row per (env, method): means and stds (success as fractions 0–1), paper values as fractions."""
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(
            ["env", "method", "n_seeds", "seeds"]
            + [f"{k}_{s}" for k in FIELDS for s in ("mean", "std")]
            + [f"paper_{k}" for k in PAPER_FIELDS]
        )
        for s in stats:
            cells: list[Any] = [s.env, s.method, len(s.seeds), " ".join(map(str, s.seeds))]
            for k in FIELDS:
                v = s.values[k]
                cells += ["", ""] if v is None else [v.mean, "" if math.isnan(v.std) else v.std]
            for k in PAPER_FIELDS:
                p = _paper(papers.get(s.env), k, s.method)
                cells.append("" if p is None else (p / 100.0 if k in PERCENT_FIELDS else p))
            w.writerow(cells)
    return path


def stats_markdown(tests: Sequence[WelchTest], fits: Sequence[ChiFit], reference: str) -> str:
    lines = ["# Study statistics", "", CONVENTIONS, "", f"## Welch t-tests: {reference} vs each method", ""]
    if tests:
        lines += _table(
            [
                "env",
                "field",
                "method",
                f"n {reference}",
                "n",
                f"mean {reference}",
                "mean",
                "difference [95% CI]",
                "t",
                "p",
                "",
                "seeds for power 0.8",
                "note",
            ],
            [
                [
                    t.env,
                    t.field,
                    t.method,
                    str(t.n_reference),
                    str(t.n_method),
                    f"{t.mean_reference:.3f}",
                    f"{t.mean_method:.3f}",
                    _interval(t),
                    _num(t.statistic),
                    _num(t.p_value),
                    significance_stars(t.p_value),
                    _seeds(t.seeds_needed),
                    t.note,
                ]
                for t in tests
            ],
        )
        lines += [
            "",
            "A difference is resolved when its interval excludes 0. *Seeds for power 0.8*: seeds per method a "
            "two-sided two-sample t-test at α = 0.05 needs to detect the observed difference with probability "
            "0.8 (Cohen's d, pooled std); where it exceeds the study's seeds the difference is not resolved by "
            "this study.",
        ]
    else:
        lines.append(f"No tests: no calibrated-χ runs of {reference} or of any other method.")
    lines += ["", "## χ sensitivity: r² of log10(χ) vs success", ""]
    if fits:
        lines += _table(
            ["env", "method", "field", "runs", "r", "r²", "p", "note"],
            [[c.env, c.method, c.field, str(c.n), _num(c.r), _num(c.r_squared), _num(c.p_value), c.note] for c in fits],
        )
    else:
        lines.append("No fixed-χ runs.")
    return "\n".join(lines) + "\n"


def _interval(t: WelchTest) -> str:
    if math.isnan(t.diff_low):
        return "n/a"
    return f"{t.mean_reference - t.mean_method:+.3f} [{t.diff_low:+.3f}, {t.diff_high:+.3f}]"


def _seeds(n: float) -> str:
    if math.isnan(n):
        return "n/a"
    return "> 100,000" if math.isinf(n) else f"{int(n):,}"


def collapses_section(runs: Sequence[StudyRun]) -> str:
    """``## Collapses``: evaluations below 10% after an earlier one of the same run reached 90%, per run name
    (a method's variants and knob values are rows of their own, as in the results table)."""
    counts = count_collapses(((r.env, r.run_name), f"seed_{r.seed}", r.episodes) for r in runs)
    if not counts:
        return ""
    rows = []
    for env, methods in by_env_method(runs, by_run_name=True).items():
        for method in methods:
            c = counts[(env, method)]
            rows.append(
                [env, method, str(c.runs), f"{c.collapses} of {c.evaluations}", "; ".join(c.collapsed_runs) or "–"]
            )
    t = total(counts.values())
    lines = [
        "## Collapses",
        "",
        f"An evaluation collapses when the robot alone succeeds in fewer than {LOW:.0%} of its test "
        f"episodes although an earlier evaluation of the same run reached {HIGH:.0%}. In all: {t.collapses} of "
        f"{t.evaluations} evaluations ({(t.rate or 0.0):.1%}), in {len(t.collapsed_runs)} of {t.runs} runs.",
        "",
    ]
    return "\n".join(lines + _table(["env", "method", "runs", "collapsed evaluations", "where"], rows)) + "\n"


def _figure_name(stem: str, env: str, envs: Sequence[str]) -> str:
    return f"{stem}.png" if len(envs) == 1 else f"{stem}_{env}.png"


def _figures(
    runs: list[StudyRun],
    env: str,
    envs: Sequence[str],
    out: Path,
    reference: str,
    tests: Sequence[WelchTest],
    fits: Sequence[ChiFit],
    points: Sequence[ChiPoint],
    paper: Any,
) -> tuple[dict[str, Path], list[str]]:
    files: dict[str, Path] = {}
    notes: list[str] = []
    env_runs = [r for r in runs if r.env == env]
    groups = by_env_method(main_runs(env_runs)).get(env, {})
    if groups:
        interactive = {m: values_of(g, "interactive_success") for m, g in groups.items()}
        p_values = {t.method: t.p_value for t in tests if t.env == env and t.field == "interactive_success"}
        name = _figure_name("fig3c_interactive", env, envs)
        files[name] = interactive_boxplot(
            interactive, p_values, reference, out / name, paper and paper["interactive_success"], title=env
        )
        name = _figure_name("fig3c_autonomous", env, envs)
        files[name] = autonomous_vs_expert_actions(
            {m: [r.curve for r in g] for m, g in groups.items()},
            out / name,
            paper and paper["autonomous_success"],
            title=env,
        )
        name = _figure_name("fig3a_maps", env, envs)
        path, note = plot_study_maps(main_runs(env_runs), out / name)
        notes.append(f"{env}: {note}")
        if path is not None:
            files[name] = path
    staged_runs = main_runs(env_runs)
    stages = stage_order((r for run in staged_runs for r in run.episodes), staged_runs)
    if stages:
        name = _figure_name("stages", env, envs)
        files[name] = stage_bars(
            {
                "autonomous test episodes, last iteration": stage_counts(staged_runs, "final_eval"),
                "interactive episodes": stage_counts(staged_runs, "interactive"),
            },
            stages,
            out / name,
            title=f"{env}: how far the episodes got",
        )
    env_points = [p for p in points if p.env == env]
    if env_points:
        name = _figure_name("fig3d_chi_sensitivity", env, envs)
        files[name] = chi_sensitivity(env_points, [f for f in fits if f.env == env], out / name, title=env)
    return files, notes


def write_study_report(
    roots: str | Path | Sequence[str | Path],
    out_dir: str | Path,
    reference: str = "dpiil_ucb",
    paper_dir: str | Path | None = None,
) -> dict[str, Any]:
    """Write the study report of every finished run below ``roots`` into ``out_dir``; return what it found."""
    roots = [roots] if isinstance(roots, (str, Path)) else list(roots)
    runs = load_study(roots)
    if not runs:
        raise FileNotFoundError(
            f"runs = {[str(r) for r in roots]}: no finished run below it (expected run directories with summary.json)"
        )
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    main = main_runs(runs)
    stats, tests = method_stats(main), welch_tests(main, reference)
    fits, points = chi_correlations(runs), chi_points(runs)
    envs = sorted({r.env for r in runs})
    papers = {env: load_paper_reference(env, paper_dir) for env in envs}
    notes = [
        f"{env}: reference method {reference!r} has no calibrated-χ runs, so no t-tests"
        for env in envs
        if not any(r.env == env and r.method == reference for r in main)
    ] + dataset_mismatches(runs)
    notes += [note for note in (machines_note(runs), code_note(runs)) if note]
    files: dict[str, Path] = {}
    for env in envs:
        figs, fig_notes = _figures(runs, env, envs, out, reference, tests, fits, points, papers[env])
        files.update(figs)
        notes += fig_notes
    staged = "\n".join(part for part in (stages_section(main), gate_stages_section(main)) if part)
    (out / "results.md").write_text(results_markdown(stats, points, papers, notes, staged, collapses_section(main)))
    write_results_csv(stats, papers, out / "results.csv")
    (out / "stats.md").write_text(stats_markdown(tests, fits, reference))
    result: dict[str, Any] = {
        "roots": [str(r) for r in roots],
        "out_dir": str(out),
        "reference": reference,
        "runs": len(runs),
        "sensitivity_runs": len(runs) - len(main),
        "conventions": CONVENTIONS,
        "method_stats": stats,
        "welch_tests": tests,
        "chi_correlations": fits,
        "chi_points": points,
        "papers": papers,
        "notes": notes,
    }
    serial = {
        k: ([asdict(x) for x in v] if k in ("method_stats", "welch_tests", "chi_correlations", "chi_points") else v)
        for k, v in result.items()
    }
    (out / "stats.json").write_text(json.dumps(clean_json(serial), indent=2) + "\n")
    files.update({n: out / n for n in ("results.md", "results.csv", "stats.md", "stats.json")})
    frontier_files, frontier_data = frontier_section(main, out, envs, reference)
    if frontier_files:
        files.update(frontier_files)
        serial.update(clean_json(frontier_data))
        (out / "stats.json").write_text(json.dumps(clean_json(serial), indent=2) + "\n")
    files["index.html"] = write_html_report(runs, out, result)  # browsable view: index.html + runs/<run>.html
    result["files"] = {n: str(p) for n, p in sorted(files.items())}
    return result


def summary_text(result: dict[str, Any]) -> str:
    """A one-screen plain-text summary of :func:`write_study_report`'s result."""
    tests = {(t.env, t.method, t.field): t.p_value for t in result["welch_tests"]}
    cols = ["env", "method", "n", "interactive", "autonomous", "expert act.", "collisions", "p(inter.)", "p(auto.)"]
    rows = []
    for s in result["method_stats"]:
        p = [tests.get((s.env, s.method, f)) for f in TESTED_FIELDS]
        rows.append(
            [s.env, s.method, str(len(s.seeds))]
            + [
                _fmt(s.values[f], f in PERCENT_FIELDS)
                for f in ("interactive_success", "autonomous_success", "expert_actions", "collisions")
            ]
            + [
                "ref"
                if s.method == result["reference"]
                else ("–" if x is None else "n/a" if math.isnan(x) else f"{_num(x, 2)} {significance_stars(x)}")
                for x in p
            ]
        )
    widths = [max(len(c), *(len(r[i]) for r in rows)) if rows else len(c) for i, c in enumerate(cols)]
    lines = [
        f"== study report: {result['runs']} runs ({result['sensitivity_runs']} fixed-χ) from "
        f"{', '.join(result['roots'])} ==",
        "  ".join(c.ljust(w) for c, w in zip(cols, widths)),
    ]
    lines += ["  ".join(c.ljust(w) for c, w in zip(r, widths)) for r in rows]
    for c in result["chi_correlations"]:
        lines.append(f"χ sensitivity {c.env} · {c.method} · {c.field}: r² = {_num(c.r_squared, 2)} over {c.n} runs")
    lines += [f"note: {n}" for n in result["notes"]]
    lines.append(f"wrote {result['out_dir']}/: " + ", ".join(Path(p).name for p in result["files"].values()))
    return "\n".join(lines)
