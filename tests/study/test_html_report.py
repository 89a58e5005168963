"""The HTML study report: every link and image resolves inside the report folder, every table has rows,
run pages carry their config, and the folder still works after being moved."""

from __future__ import annotations

import html
import shutil
from html.parser import HTMLParser
from pathlib import Path

import matplotlib.pyplot as plt
import pytest

from dpiil_rl.study.html_report import markdown_to_html, page_stem
from dpiil_rl.study.study_report import write_study_report
from dpiil_rl.study.study_runs import load_study
from tests.study.synthetic_runs import write_chi_study, write_run, write_study


class PageParser(HTMLParser):
    """Image sources, link targets, and the body-row count of every table of one page."""

    def __init__(self) -> None:
        super().__init__()
        self.images: list[str] = []
        self.links: list[str] = []
        self.table_rows: list[int] = []
        self.in_tbody = False
        self.text: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        if tag == "img":
            self.images.append(a["src"] or "")
        elif tag == "a" and a.get("href"):
            self.links.append(a["href"] or "")
        elif tag == "table":
            self.table_rows.append(0)
        elif tag == "tbody":
            self.in_tbody = True
        elif tag == "tr" and self.in_tbody:
            self.table_rows[-1] += 1

    def handle_endtag(self, tag: str) -> None:
        if tag == "tbody":
            self.in_tbody = False

    def handle_data(self, data: str) -> None:
        self.text.append(data)


def parse(path: Path) -> PageParser:
    parser = PageParser()
    parser.feed(path.read_text(encoding="utf-8"))
    return parser


def is_relative(url: str) -> bool:
    return "://" not in url and not url.startswith(("/", "#", "mailto:", "data:"))


def add_plots(run_dir: Path) -> None:
    """What the trainer writes into ``plots/``: small real PNGs."""
    (run_dir / "plots").mkdir()
    for i, name in enumerate(("learning_curve", "maps_initial", "maps_final")):
        fig, ax = plt.subplots(figsize=(2, 1.5))
        ax.plot([0, 1, 2], [0, i, 2 * i])
        fig.savefig(run_dir / "plots" / f"{name}.png", dpi=50)
        plt.close(fig)


@pytest.fixture(scope="module")
def html_report(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("html_study")
    dirs = write_study(tmp / "main")
    write_chi_study(tmp / "chi", chis=(1e-4, 1e-3), seeds=2)
    for d in dirs[:3]:
        add_plots(d)
    out = tmp / "report"
    result = write_study_report([tmp / "main", tmp / "chi"], out)
    return result, out, tmp


def check_page(page: Path) -> PageParser:
    parsed = parse(page)
    for src in parsed.images:
        assert is_relative(src), (page, src)
        assert (page.parent / src).is_file(), (page, src)
    for href in parsed.links:
        if is_relative(href):
            assert (page.parent / href).is_file(), (page, href)
    assert parsed.table_rows and all(n > 0 for n in parsed.table_rows), (page, parsed.table_rows)
    return parsed


def test_index_is_written_and_listed(html_report):
    result, out, _ = html_report
    assert result["files"]["index.html"] == str(out / "index.html")
    index = check_page(out / "index.html")
    # every study figure is shown, and only figures of this folder
    assert sorted(index.images) == sorted(p.name for p in out.glob("*.png")) and index.images
    # results and collapses tables, a χ table, Welch tests, χ fits, and the run table
    assert len(index.table_rows) == 6
    text = "".join(index.text)
    assert "dpiil_ucb" in text and "my_new_method" in text and "Welch" in text


def test_every_run_has_a_linked_page_with_its_config(html_report):
    result, out, tmp = html_report
    runs = load_study([tmp / "main", tmp / "chi"])
    index = parse(out / "index.html")
    run_links = [h for h in index.links if h.startswith("runs/")]
    assert len(run_links) == len(set(run_links)) == len(runs) == result["runs"]
    assert index.table_rows[-1] == len(runs)
    for run in runs:
        page = out / "runs" / f"{page_stem(run)}.html"
        assert f"runs/{page.name}" in run_links
        parsed = check_page(page)
        assert "../index.html" in parsed.links
        html_text = page.read_text(encoding="utf-8")
        config = (run.run_dir / ".hydra" / "config.yaml").read_text()
        assert f"<pre>{html.escape(config)}</pre>" in html_text and "seed:" in config
        assert len(parsed.table_rows) == 2 and parsed.table_rows[1] == len(run.metrics)  # summary + metrics
        plots = sorted(p.name for p in (run.run_dir / "plots").glob("*.png"))
        assert sorted(Path(s).name for s in parsed.images) == plots
        for name in plots:  # copied, not referenced in place
            assert (out / "runs" / page_stem(run) / name).is_file()


def test_report_folder_is_movable(html_report, tmp_path):
    _, out, _ = html_report
    moved = tmp_path / "elsewhere" / "report"
    shutil.copytree(out, moved)
    check_page(moved / "index.html")
    for page in (moved / "runs").glob("*.html"):
        check_page(page)


def test_text_is_escaped(tmp_path):
    write_run(tmp_path / "runs", "dagger", 0, [0.5], [0.2, 0.6], env="a<b>&c", run_name="x<script>")
    out = tmp_path / "report"
    write_study_report(tmp_path / "runs", out)
    index = (out / "index.html").read_text()
    assert "a<b>" not in index and "a&lt;b&gt;&amp;c" in index
    page = next((out / "runs").glob("*.html"))
    assert page.read_text().count("<script>") == 1  # only the inline check script
    check_page(out / "index.html")
    check_page(page)


def test_markdown_subset():
    text = "# T\n\nsome `code` & <x>\n\n| a | b |\n|---|---|\n| 1 | <2> |\n\n- item\n"
    out = markdown_to_html(text)
    assert "<h2>T</h2>" in out and "<code>code</code> &amp; &lt;x&gt;" in out
    assert "<th>a</th>" in out and "<td>&lt;2&gt;</td>" in out and "<li>item</li>" in out
