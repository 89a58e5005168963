"""A self-contained HTML view of a study report, readable offline in a browser.

:func:`write_html_report` writes ``<out_dir>/index.html`` next to the study report's files: the results and
statistics tables (converted from ``results.md``/``stats.md``, so the numbers are exactly the markdown's),
every study figure (``*.png`` in ``out_dir``), and a table of all runs linking to one page per run,
``runs/<env>__<run_name>__seed_<s>.html``, with the run's summary, per-iteration metrics, plots (copied to
``runs/<page-stem>/`` so the folder can be moved as a whole) and resolved config.

No external JS, CSS or fonts: one inline ``<style>`` and one inline ``<script>`` per page. The script, on
``load``, records what the browser rendered on ``<body>``: ``data-images-ok`` / ``data-tables-ok`` are
``"true"`` when every ``<img>`` decoded (``naturalWidth > 0``) / every ``<table>`` has a body row, and
``data-images`` / ``data-tables`` count them (``"loaded/total"``), for headless checks (``chromium --dump-dom``).
All text is escaped with :func:`html.escape`.
"""

from __future__ import annotations

import html
import math
import os
import re
import shutil
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from omegaconf import OmegaConf

from dpiil_rl.study.study_runs import StudyRun, method_order

STYLE = """
body{font-family:system-ui,-apple-system,"Segoe UI",sans-serif;margin:1.5em auto;max-width:1350px;\
padding:0 1em;color:#222}
h1,h2,h3{margin-top:1.3em}table{border-collapse:collapse;margin:.6em 0;font-size:13px}
th,td{border:1px solid #ccc;padding:3px 7px;text-align:left;vertical-align:top}th{background:#eef1f5}
tbody tr:nth-child(even){background:#f8f9fb}.scroll{overflow-x:auto}
img{max-width:100%;border:1px solid #ddd;margin:.4em 0}figure{margin:0}
.figs{display:grid;grid-template-columns:1fr 1fr;gap:1em;align-items:start}.figs .wide{grid-column:1/3}
figcaption{font-size:12px;color:#555}pre{background:#f6f8fa;padding:.8em;overflow-x:auto;font-size:12px}
code{background:#f0f0f0;padding:0 3px}
"""

#: sets data-images-ok / data-tables-ok (and counts) on <body> once the page has loaded
CHECK_SCRIPT = """
window.addEventListener("load", function () {
  var imgs = Array.prototype.slice.call(document.images);
  var ok = imgs.filter(function (i) { return i.complete && i.naturalWidth > 0; }).length;
  var tables = Array.prototype.slice.call(document.querySelectorAll("table"));
  var rows = tables.filter(function (t) { return t.querySelectorAll("tbody tr").length > 0; }).length;
  var b = document.body.dataset;
  b.images = ok + "/" + imgs.length; b.imagesOk = String(ok === imgs.length);
  b.tables = rows + "/" + tables.length; b.tablesOk = String(rows === tables.length);
});
"""

E = html.escape
#: run plots in reading order (others follow alphabetically)
PLOT_ORDER = {"learning_curve": 0, "maps_initial": 1, "maps_final": 2}
BACK = '<p><a href="../index.html">← study report</a></p>'


def _page(title: str, body: Iterable[str]) -> str:
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        f"<title>{E(title)}</title><style>{STYLE}</style><script>{CHECK_SCRIPT}</script></head>\n<body>\n"
        + "\n".join(body)
        + "\n</body></html>\n"
    )


def _inline(text: str) -> str:
    """Escape ``text``, turning markdown ``code`` spans into ``<code>``."""
    return re.sub(r"`([^`]*)`", lambda m: f"<code>{m.group(1)}</code>", E(text))


def html_table(header: Sequence[str], rows: Sequence[Sequence[str]], raw: bool = False) -> str:
    """A table; cells are escaped unless ``raw`` (then the caller escaped them)."""
    cell = (lambda c: c) if raw else _inline
    head = "".join(f"<th>{_inline(h)}</th>" for h in header)
    body = "\n".join("<tr>" + "".join(f"<td>{cell(c)}</td>" for c in r) + "</tr>" for r in rows)
    return f'<div class="scroll"><table><thead><tr>{head}</tr></thead>\n<tbody>\n{body}\n</tbody></table></div>'


def markdown_to_html(text: str, level_offset: int = 1) -> str:
    """The subset of markdown the study report writes: headings, pipe tables, ``-`` lists, images, paragraphs."""
    out: list[str] = []
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        line = lines[i].rstrip()
        if line.startswith("|"):
            block = []
            while i < len(lines) and lines[i].startswith("|"):
                block.append([c.strip() for c in lines[i].strip().strip("|").split("|")])
                i += 1
            rows = [r for r in block[1:] if not all(re.fullmatch(r":?-+:?", c) for c in r)]
            out.append(html_table(block[0], rows))
            continue
        if line.startswith("- "):
            items = []
            while i < len(lines) and lines[i].startswith("- "):
                items.append(f"<li>{_inline(lines[i][2:])}</li>")
                i += 1
            out.append("<ul>" + "".join(items) + "</ul>")
            continue
        heading = re.match(r"(#+) (.*)", line)
        image = re.fullmatch(r"!\[([^\]]*)\]\(([^)]+)\)", line)
        if image:  # a figure of the report folder
            out.append(f'<figure><img src="{E(image.group(2))}" alt="{E(image.group(1))}"></figure>')
        elif heading:
            level = min(6, len(heading.group(1)) + level_offset)
            out.append(f"<h{level}>{_inline(heading.group(2))}</h{level}>")
        elif line:
            out.append(f"<p>{_inline(line)}</p>")
        i += 1
    return "\n".join(out)


def _figures(figures: Sequence[str]) -> str:
    return '<div class="figs">' + "\n".join(figures) + "</div>"


def page_stem(run: StudyRun) -> str:
    """``<env>__<run_name>__seed_<s>`` with anything but letters, digits, ``._-`` replaced by ``_``."""
    return re.sub(r"[^A-Za-z0-9._-]", "_", f"{run.env}__{run.run_name}__seed_{run.seed}")


def _cell(value: Any) -> str:
    if value is None:
        return "–"
    if isinstance(value, float):
        return "n/a" if math.isnan(value) else f"{value:.4g}"
    return str(value)


def _pct(value: Any) -> str:
    return "–" if value is None else f"{100 * float(value):.1f}%"


def _sorted_runs(runs: Sequence[StudyRun]) -> list[StudyRun]:
    order = {m: i for i, m in enumerate(method_order(r.method for r in runs))}
    return sorted(runs, key=lambda r: (r.env, r.chi_fixed is not None, order[r.method], r.chi_fixed or 0.0, r.seed))


def _run_row(run: StudyRun, href: str) -> list[str]:
    s = run.summary
    return [
        E(run.env),
        f'<a href="{E(href)}">{E(run.method)}</a>',
        E(str(run.seed)),
        "calibrated" if run.chi_fixed is None else E(f"{run.chi_fixed:.2e}"),
        _pct(s.get("interactive_success")),
        _pct(s.get("autonomous_success")),
        E(_cell(s.get("expert_actions"))),
    ]


def write_run_page(run: StudyRun, runs_dir: Path) -> Path:
    """``runs_dir/<stem>.html`` for one run, its plots copied to ``runs_dir/<stem>/``."""
    stem = page_stem(run)
    plots = sorted(
        (run.run_dir / "plots").glob("*.png"), key=lambda p: (PLOT_ORDER.get(p.stem, len(PLOT_ORDER)), p.name)
    )
    figures = []
    if plots:
        (runs_dir / stem).mkdir(parents=True, exist_ok=True)
    for plot in plots:
        shutil.copy2(plot, runs_dir / stem / plot.name)
        figures.append(
            f'<figure><img src="{E(stem)}/{E(plot.name)}" alt="{E(plot.stem)}">'
            f"<figcaption>{E(plot.name)}</figcaption></figure>"
        )
    summary = {**run.recorded, **run.summary}
    columns: list[str] = []
    for row in run.metrics:
        columns += [k for k in row if k not in columns]
    config_path = run.run_dir / ".hydra" / "config.yaml"
    config = config_path.read_text(encoding="utf-8") if config_path.exists() else OmegaConf.to_yaml(run.config)
    body = [
        BACK,
        f"<h1>{E(run.env)} · {E(run.method)} · seed {E(str(run.seed))}</h1>",
        f"<p>Run directory: <code>{E(os.path.relpath(run.run_dir))}</code></p>",  # relative: no machine paths
        "<h2>Summary</h2>",
        html_table(["field", "value"], [[k, _cell(v)] for k, v in summary.items()]),
        "<h2>Per-iteration metrics</h2>",
        html_table(columns, [[_cell(row.get(c)) for c in columns] for row in run.metrics])
        if run.metrics
        else "<p>No metrics.jsonl rows.</p>",
        "<h2>Plots</h2>",
        _figures(figures) if figures else "<p>No plots/*.png in this run.</p>",
        "<h2>Resolved config (.hydra/config.yaml)</h2>",
        f"<pre>{E(config)}</pre>",
        BACK,
    ]
    path = runs_dir / f"{stem}.html"
    path.write_text(_page(f"{run.env} {run.run_name} seed {run.seed}", body), encoding="utf-8")
    return path


def write_html_report(runs: list[StudyRun], out_dir: Path, result: dict[str, Any]) -> Path:
    """Write ``out_dir/index.html`` and one page per run; ``out_dir`` already holds the study report's files."""
    out_dir = Path(out_dir)
    runs_dir = out_dir / "runs"
    runs_dir.mkdir(parents=True, exist_ok=True)
    rows = []
    for run in _sorted_runs(runs):
        page = write_run_page(run, runs_dir)
        rows.append(_run_row(run, f"runs/{page.name}"))
    figures = sorted(p.name for p in out_dir.glob("*.png"))
    body = [
        "<h1>Study report</h1>",
        f"<p>{E(str(result.get('runs', len(runs))))} runs ({E(str(result.get('sensitivity_runs', 0)))} fixed-χ) "
        f"from <code>{E(', '.join(map(str, result.get('roots', []))))}</code>; reference method "
        f"<code>{E(str(result.get('reference', '')))}</code>. Files: "
        + ", ".join(
            f'<a href="{E(n)}">{E(n)}</a>'
            for n in ("results.md", "results.csv", "stats.md", "stats.json", "frontier.md")
            if (out_dir / n).exists()
        )
        + ".</p>",
    ]
    for name in ("results.md", "stats.md", "frontier.md"):
        if (out_dir / name).exists():
            body.append(markdown_to_html((out_dir / name).read_text(encoding="utf-8")))
    body.append("<h2>Figures</h2>")
    wide = ' class="wide"'  # the maps panel is a wide row of small maps: give it the full width
    body.append(
        _figures(
            [
                f'<figure{wide if "maps" in n else ""}><img src="{E(n)}" alt="{E(n)}">'
                f"<figcaption>{E(n)}</figcaption></figure>"
                for n in figures
            ]
        )
        if figures
        else "<p>No figures.</p>"
    )
    body += [
        "<h2>All runs</h2>",
        html_table(
            ["env", "method", "seed", "χ", "interactive success", "autonomous success (final)", "expert actions"],
            rows,
            raw=True,
        ),
    ]
    index = out_dir / "index.html"
    index.write_text(_page("Study report", body), encoding="utf-8")
    return index
