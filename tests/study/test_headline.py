"""Headline tables: rendered from a study's records, and every committed one equal to its records."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from omegaconf import OmegaConf

from dpiil_rl.study.headline import MARK, refresh_headlines
from tests.study.synthetic_runs import write_study

REPO = Path(__file__).resolve().parents[2]


def test_a_block_is_filled_from_the_records_and_a_stale_one_is_found(tmp_path: Path) -> None:
    write_study(tmp_path / "results")
    page = tmp_path / "page.md"
    page.write_text(
        "intro\n<!-- headline:synthetic -->\nstale\n<!-- /headline -->\n"
        "<!-- collapses:synthetic -->\nstale\n<!-- /collapses -->\n"
        "<!-- frontier:synthetic -->\nstale\n<!-- /frontier -->\nend\n"
    )
    text, studies = refresh_headlines(page, tmp_path / "results")
    assert studies == ["synthetic", "synthetic", "synthetic"]
    assert "No frontier runs to compare yet." in text  # the synthetic study has no knob sweep
    assert "stale" not in text and text.startswith("intro\n") and text.endswith("end\n")
    assert "| method | seeds | interactive success [95% CI]" in text and "| all | |" in text
    page.write_text(text)
    again, _ = refresh_headlines(page, tmp_path / "results")
    assert again == text  # a fresh table is a fixed point
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "dpiil_rl.cli.headlines",
            f"pages=[{page}]",
            f"results={tmp_path / 'results'}",
            "check=true",
        ],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert out.returncode == 0, out.stderr
    page.write_text(text.replace("| 2 |", "| 3 |", 1))
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "dpiil_rl.cli.headlines",
            f"pages=[{page}]",
            f"results={tmp_path / 'results'}",
            "check=true",
        ],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert out.returncode == 1


_LOADED: dict[Path, list] = {}  # the committed studies, read once for all the pages that show them


def _committed_pages() -> list[str]:
    cfg = OmegaConf.load(REPO / "dpiil_rl" / "configs" / "headlines.yaml")
    return [str(p) for p in cfg.pages]


@pytest.mark.parametrize("page", _committed_pages())
def test_every_committed_headline_table_is_what_its_records_give(page: str) -> None:
    path = REPO / page
    text = path.read_text()
    assert MARK.search(text), f"{page}: no headline block (configs/headlines.yaml lists it)"
    fresh, studies = refresh_headlines(path, REPO / "docs" / "results", _LOADED)
    assert fresh == text, f"{page}: a headline table differs from the records of {studies}; run make headlines"
