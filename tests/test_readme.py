"""The README is a landing page: at most 250 lines, and every page it links exists."""

from __future__ import annotations

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
LINK = re.compile(r"\]\(([^)\s#]+)(?:#[^)]*)?\)")


def test_the_readme_is_short_and_its_links_resolve() -> None:
    text = (REPO / "README.md").read_text()
    assert len(text.splitlines()) <= 250
    missing = [
        t
        for t in LINK.findall(text)
        if not t.startswith(("http://", "https://", "mailto:")) and not (REPO / t).exists()
    ]
    assert not missing, f"README links to missing files: {missing}"
