"""The HTML study report in a real browser: headless Chromium (Debian's ``chromium``, driven by its own CLI).

Every page of the report carries an inline script that, on ``load``, writes what the browser rendered onto
``<body>`` (``data-images-ok``/``data-tables-ok``, see :mod:`dpiil_rl.study.html_report`);
``chromium --dump-dom --virtual-time-budget=5000`` lets the load event fire, then prints the DOM, and the test
reads those attributes. A screenshot of the index goes to the test's tmp dir, and also to
``docs/img/report_screenshot.png`` when ``DPIIL_SAVE_SCREENSHOT=1``.

Without ``chromium`` on PATH the setup runs ``apt-get install -y chromium`` (as root only); when that is
impossible the test is skipped with a message naming the command.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from dpiil_rl.study.study_report import write_study_report
from tests.conftest import ROOT
from tests.study.synthetic_runs import write_chi_study, write_study
from tests.study.test_html_report import add_plots
from tests.system_packages import find_or_install


def find_or_install_chromium() -> str:
    """Path of ``chromium``; installs Debian's package if missing and possible, else skips the test."""
    return find_or_install("chromium", "chromium")


def chromium(binary: str, *args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run(
        [
            binary,
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--hide-scrollbars",
            "--virtual-time-budget=5000",
            *args,
        ],
        check=False,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def body_checks(binary: str, page: Path) -> dict[str, str]:
    """The ``data-*`` attributes the page's inline script set on ``<body>`` after loading in Chromium."""
    proc = chromium(binary, "--dump-dom", page.resolve().as_uri())
    body = re.search(r"<body([^>]*)>", proc.stdout)
    assert body, f"no <body> in chromium's DOM dump of {page}: {proc.stderr[-1000:]}"
    return dict(re.findall(r'data-([\w-]+)="([^"]*)"', body.group(1)))


@pytest.fixture(scope="module")
def browser() -> str:
    return find_or_install_chromium()


@pytest.fixture(scope="module")
def report(tmp_path_factory) -> Path:
    tmp = tmp_path_factory.mktemp("browser_study")
    dirs = write_study(tmp / "main")
    write_chi_study(tmp / "chi", chis=(1e-4, 1e-3), seeds=2)
    add_plots(dirs[0])
    out = tmp / "report"
    write_study_report([tmp / "main", tmp / "chi"], out)
    return out


def test_index_renders_in_chromium(browser, report, tmp_path):
    checks = body_checks(browser, report / "index.html")
    assert checks.get("images-ok") == "true", checks
    assert checks.get("tables-ok") == "true", checks
    assert int(checks["images"].split("/")[1]) >= 3 and int(checks["tables"].split("/")[1]) >= 5, checks
    shot = tmp_path / "report_screenshot.png"
    proc = chromium(browser, f"--screenshot={shot}", "--window-size=1400,2000", (report / "index.html").as_uri())
    assert shot.is_file() and shot.stat().st_size > 10_000, proc.stderr[-1000:]
    assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    if os.environ.get("DPIIL_SAVE_SCREENSHOT") == "1":
        target = ROOT / "docs" / "img" / "report_screenshot.png"
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(shot, target)


def test_run_page_renders_in_chromium(browser, report):
    pages = sorted((report / "runs").glob("*.html"))
    with_plots = [p for p in pages if (report / "runs" / p.stem).is_dir()]
    assert with_plots
    for page in (with_plots[0], pages[-1]):
        checks = body_checks(browser, page)
        assert checks.get("images-ok") == "true" and checks.get("tables-ok") == "true", (page, checks)
    assert body_checks(browser, with_plots[0])["images"] == "3/3"
