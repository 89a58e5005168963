"""Recompute every headline table (``<!-- headline:<study> -->`` blocks) of the README and the results pages
from the committed records in ``docs/results/<study>``: ``dpiil-headlines`` (or ``make headlines``);
``check=true`` only reports the blocks that differ (exit 1) — what the test suite does."""

from __future__ import annotations

import sys
from pathlib import Path

import hydra
from omegaconf import DictConfig

from dpiil_rl.study.headline import refresh_headlines
from dpiil_rl.study.study_runs import StudyRun
from dpiil_rl.utils.cli import report_user_errors


@hydra.main(config_path="../configs", config_name="headlines", version_base="1.3")
@report_user_errors
def run(cfg: DictConfig) -> None:
    stale = []
    loaded: dict[Path, list[StudyRun]] = {}  # each study's records read once for every page that shows it
    for name in cfg.pages:
        page = Path(str(name))  # pages and results relative to where the command runs (the repository)
        text, studies = refresh_headlines(page, Path(str(cfg.results)), loaded)
        if text != page.read_text():
            stale.append(str(name))
            if not cfg.check:
                page.write_text(text)
        print(f"{name}: {len(studies)} headline table(s) ({', '.join(studies) or 'none'})")
    if stale:
        print(("stale: " if cfg.check else "rewrote: ") + ", ".join(stale))
        if cfg.check:
            sys.exit(1)


def main() -> None:
    """The ``dpiil-headlines`` command."""
    run()


if __name__ == "__main__":
    main()
