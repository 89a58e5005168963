"""The project speaks of itself alone: no tracked text file holds an absolute path of a machine (records keep
paths relative to their study folder)."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
MACHINE_PATH = re.compile(r"(?<![\w.~-])(/work/|/home/[a-z_][\w-]*/|/Users/|/root/|/tmp/[\w.-]|[A-Z]:\\\\)")
BINARY = {".png", ".gz", ".pt", ".npz", ".jpg", ".ico", ".pdf"}
# a file may name a path of this kind on purpose; each entry says why
ALLOWED: dict[str, str] = {
    "tests/test_no_machine_paths.py": "the patterns themselves",
}


def _tracked() -> list[str]:
    out = subprocess.run(["git", "ls-files"], capture_output=True, text=True, cwd=REPO, check=True)
    return [p for p in out.stdout.splitlines() if Path(p).suffix not in BINARY and p not in ALLOWED]


def test_no_tracked_file_holds_a_machine_path() -> None:
    found = []
    for rel in _tracked():
        path = REPO / rel
        if not path.is_file() or path.is_symlink():
            continue
        try:
            text = path.read_text()
        except UnicodeDecodeError:
            continue
        for n, line in enumerate(text.splitlines(), 1):
            if MACHINE_PATH.search(line):
                found.append(f"{rel}:{n}: {line.strip()[:120]}")
    assert not found, "absolute machine paths in tracked files:\n" + "\n".join(found[:50])


def test_the_pattern_finds_machine_paths_and_not_relative_ones() -> None:
    root = "/"  # the bad examples are built here, so this file holds no machine path itself
    bad_examples = (
        f"run_root: {root}work/x",
        f'"run_dir": "{root}home/ana/runs/a"',
        f"cd {root}tmp/abc",
        f"{root}Users/bo/x",
    )
    for bad in (*bad_examples, "C:\\\\data"):
        assert MACHINE_PATH.search(bad), bad
    for ok in ("bench/tmp/", "runs/paper/ring", "docs/results/x", "a /tmp alone", "http://host/work/"):
        assert not MACHINE_PATH.search(ok), ok
