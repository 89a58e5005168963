"""Every key of every config file is explained once, where it is defined (house style)."""

import re

import pytest

from tests.conftest import ROOT

KEY = re.compile(r"^\s*(- )?[A-Za-z_][\w.@/-]*:( |$)")
QUOTED = re.compile(r"'[^']*'|\"(?:[^\"\\]|\\.)*\"")  # a quoted scalar may hold a '#' that is no comment
COMMENT = re.compile(r"(^|\s)#")  # YAML: a comment starts with '#' at the line start or after whitespace
BLOCK_SCALAR = re.compile(r":\s*[|>][-+0-9]*\s*(#.*)?$")  # `key: |` / `key: >-`: the indented lines below are text
CONFIGS = sorted((ROOT / "configs").rglob("*.yaml"))


def has_comment(line: str) -> bool:
    return bool(COMMENT.search(QUOTED.sub("''", line)))


def indent(line: str) -> int:
    return len(line) - len(line.lstrip(" "))


@pytest.mark.parametrize("path", CONFIGS, ids=[str(p.relative_to(ROOT / "configs")) for p in CONFIGS])
def test_every_key_has_a_comment(path):
    missing = []
    text_below = None  # indentation of a key whose block-scalar text follows
    for number, line in enumerate(path.read_text().splitlines(), 1):
        if text_below is not None:
            if not line.strip() or indent(line) > text_below:
                continue  # a line of the block scalar's text, not a key
            text_below = None
        if KEY.match(line) and not has_comment(line):
            missing.append(f"{number}: {line.strip()}")
        if KEY.match(line) and BLOCK_SCALAR.search(QUOTED.sub("''", line)):
            text_below = indent(line)
    assert not missing, f"{path.relative_to(ROOT)}: keys without a comment: {missing}"
