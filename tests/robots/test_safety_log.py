"""SafetyLog: every event in memory and in the run's jsonl; warnings rate-limited per kind."""

from __future__ import annotations

import json
import logging
import time
from pathlib import Path

import numpy as np
import pytest

from dpiil_rl.robots.safety_log import EVENTS_FILE, SafetyEventKind, SafetyLog

LOGGER = "dpiil_rl.robots.safety_log"


def test_events_are_kept_counted_and_written_as_json_lines(tmp_path: Path) -> None:
    with SafetyLog.in_run_dir(tmp_path / "run") as log:
        log.record(SafetyEventKind.SPEED_CLIPPED, 1.5, requested=np.float64(3.0), allowed=0.25)
        log.record(SafetyEventKind.NON_FINITE, what="velocity", value=np.array([np.nan, np.inf, 1.0]))
        log.record(SafetyEventKind.SPEED_CLIPPED)
        assert [e.kind for e in log.events] == [
            SafetyEventKind.SPEED_CLIPPED,
            SafetyEventKind.NON_FINITE,
            SafetyEventKind.SPEED_CLIPPED,
        ]
        assert log.counts() == {SafetyEventKind.SPEED_CLIPPED: 2, SafetyEventKind.NON_FINITE: 1}
        lines = (tmp_path / "run" / EVENTS_FILE).read_text().splitlines()  # written at once, before close
    records = [json.loads(line) for line in lines]  # strict JSON: NaN / inf became strings
    assert [r["kind"] for r in records] == ["speed_clipped", "non_finite", "speed_clipped"]
    assert records[0]["robot_time"] == 1.5 and records[0]["details"] == {"requested": 3.0, "allowed": 0.25}
    assert records[1]["details"]["value"] == ["nan", "inf", 1.0]
    assert all(abs(r["time"] - time.time()) < 60 for r in records)


def test_a_second_log_appends_to_the_same_file(tmp_path: Path) -> None:
    for _ in range(2):
        with SafetyLog.in_run_dir(tmp_path) as log:
            log.record(SafetyEventKind.WATCHDOG, age=0.2)
    assert len((tmp_path / EVENTS_FILE).read_text().splitlines()) == 2


def test_memory_is_bounded_but_counts_are_exact() -> None:
    log = SafetyLog(memory=5)
    for _ in range(12):
        log.record(SafetyEventKind.ACCEL_CLIPPED)
    assert len(log.events) == 5 and log.count(SafetyEventKind.ACCEL_CLIPPED) == 12


def test_a_held_clip_warns_once_per_interval(caplog: pytest.LogCaptureFixture) -> None:
    log = SafetyLog(warn_interval=0.2)
    with caplog.at_level(logging.WARNING, logger=LOGGER):
        for _ in range(50):
            log.record(SafetyEventKind.WORKSPACE_CLIPPED, position=[0.1, 0.2, 0.3])
        log.record(SafetyEventKind.TRACKING_ERROR, error=0.07)  # another kind warns on its own
        time.sleep(0.25)
        log.record(SafetyEventKind.WORKSPACE_CLIPPED)
    messages = [r.getMessage() for r in caplog.records if r.name == LOGGER]
    assert len(messages) == 3, messages
    assert messages[0].startswith("safety: workspace_clipped: position=[0.1, 0.2, 0.3]")
    assert "tracking_error" in messages[1] and "error=0.07" in messages[1]
    assert "+49 since the last warning" in messages[2]
    assert all("\n" not in m for m in messages)
    assert log.count(SafetyEventKind.WORKSPACE_CLIPPED) == 51
