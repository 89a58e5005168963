"""The code version a run records: the checkout's commit and whether the package differs from it."""

from __future__ import annotations

import subprocess

import pytest

from dpiil_rl.utils import code_version as cv


def _head() -> str | None:
    done = subprocess.run(["git", "-C", str(cv._ROOT), "rev-parse", "HEAD"], capture_output=True, text=True)
    return done.stdout.strip() if done.returncode == 0 else None


def test_a_run_from_a_checkout_records_its_commit():
    if _head() is None:
        pytest.skip("the package is not imported from a git checkout here")
    cv.code_version.cache_clear()
    found = cv.code_version()
    assert found["commit"] == _head() and len(found["commit"]) == 40
    assert isinstance(found["dirty"], bool) and found["version"]


def test_outside_a_checkout_the_commit_is_none(tmp_path, monkeypatch):
    monkeypatch.setattr(cv, "_ROOT", tmp_path)
    cv.code_version.cache_clear()
    try:
        assert cv.code_version()["commit"] is None and cv.code_version()["dirty"] is None
    finally:
        cv.code_version.cache_clear()


def test_a_changed_tracked_file_marks_the_code_dirty(tmp_path, monkeypatch):
    git = ["git", "-C", str(tmp_path), "-c", "user.name=t", "-c", "user.email=t@t"]
    subprocess.run([*git[:3], "init", "-q"], check=True)
    (tmp_path / "dpiil_rl").mkdir()
    (tmp_path / "dpiil_rl" / "a.py").write_text("x = 1\n")
    subprocess.run([*git, "add", "."], check=True)
    subprocess.run([*git, "commit", "-qm", "a"], check=True)
    monkeypatch.setattr(cv, "_ROOT", tmp_path)
    cv.code_version.cache_clear()
    try:
        assert cv.code_version()["dirty"] is False
        (tmp_path / "dpiil_rl" / "a.py").write_text("x = 2\n")
        cv.code_version.cache_clear()
        assert cv.code_version()["dirty"] is True
    finally:
        cv.code_version.cache_clear()
