"""Recompute every headline table (``<!-- headline:<study> -->`` blocks) of the README and the results pages
from the committed records in ``docs/results/<study>``: ``python trainers/headlines.py`` (or ``make headlines``);
``check=true`` only reports the blocks that differ (exit 1) — what the test suite does."""

from __future__ import annotations

import sys
from pathlib import Path

import hydra
from omegaconf import DictConfig

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from dpiil_rl.records.headline import refresh_headlines  # noqa: E402
from dpiil_rl.utils.cli import report_user_errors  # noqa: E402


@hydra.main(config_path="../configs", config_name="headlines", version_base="1.3")
@report_user_errors
def main(cfg: DictConfig) -> None:
    stale = []
    for name in cfg.pages:
        page = ROOT / str(name)
        text, studies = refresh_headlines(page, ROOT / str(cfg.results))
        if text != page.read_text():
            stale.append(str(name))
            if not cfg.check:
                page.write_text(text)
        print(f"{name}: {len(studies)} headline table(s) ({', '.join(studies) or 'none'})")
    if stale:
        print(("stale: " if cfg.check else "rewrote: ") + ", ".join(stale))
        if cfg.check:
            sys.exit(1)


if __name__ == "__main__":
    main()
