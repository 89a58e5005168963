"""SafeRobot: every command is filtered, stops refuse motion, start poses stay in the box, events reach the jsonl."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from dpiil_rl.robots.safety_limits import SafetyLimits
from dpiil_rl.robots.safety_log import EVENTS_FILE, SafetyEventKind, SafetyLog
from dpiil_rl.robots.safety_robot import SafeRobot, SafetyRefusal
from tests.mocks.integrator_robot import IntegratorRobot

LIMITS = SafetyLimits(
    low=np.array([-0.3, -0.7, 0.05]),
    high=np.array([0.3, -0.25, 0.45]),
    max_speed=0.25,
    max_acceleration=1.0,
    max_tracking_error=0.05,
)
CENTER = (LIMITS.low + LIMITS.high) / 2


def make(position=CENTER, log: SafetyLog | None = None) -> tuple[SafeRobot, IntegratorRobot, SafetyLog]:
    arm = IntegratorRobot(position, control_period=0.05)
    log = log if log is not None else SafetyLog()
    robot = SafeRobot(arm, LIMITS, log)
    robot.connect()
    return robot, arm, log


def test_commands_reach_the_arm_filtered_with_a_bounded_acceleration() -> None:
    robot, arm, _ = make()
    assert robot.control_period == arm.control_period and robot.is_connected
    for _ in range(3):
        robot.command_tcp_velocity(np.array([1.0, 0.0, 0.0]), acceleration=5.0)
    velocities = [v for v, _ in arm.commands]
    np.testing.assert_allclose([v[0] for v in velocities], [0.05, 0.10, 0.15])
    assert all(acc == pytest.approx(LIMITS.max_acceleration) for _, acc in arm.commands)  # 5.0 capped
    robot.command_tcp_velocity(np.array([0.15, 0.0, 0.0]), acceleration=0.2)  # gentler: kept
    assert arm.commands[-1][1] == pytest.approx(0.2)
    robot.disconnect()
    assert not robot.is_connected


def test_braking_harder_than_the_limit_is_passed_on_to_the_arm() -> None:
    robot, arm, _ = make(position=[LIMITS.high[0] - 0.001, -0.45, 0.25])
    robot.filter.reset([0.25, 0.0, 0.0])  # e.g. re-synchronised while the arm still moved
    robot.command_tcp_velocity(np.array([0.25, 0.0, 0.0]), acceleration=1.0)
    velocity, acceleration = arm.commands[-1]
    assert arm.position[0] <= LIMITS.high[0]
    assert acceleration == pytest.approx((0.25 - velocity[0]) / arm.control_period)
    assert acceleration > LIMITS.max_acceleration


def test_protective_stop_refuses_motion_until_it_is_cleared() -> None:
    robot, arm, log = make()
    for _ in range(4):
        robot.command_tcp_velocity(np.array([0.2, 0.0, 0.0]), 1.0)
    arm.protective_stop = True
    position = arm.position.copy()
    robot.command_tcp_velocity(np.array([0.2, 0.0, 0.0]), 1.0)
    robot.command_tcp_velocity(np.array([0.2, 0.0, 0.0]), 1.0)
    assert len(arm.commands) == 4 and len(arm.stops) == 2  # refused: stop instead
    np.testing.assert_array_equal(arm.position, position)
    assert log.count(SafetyEventKind.PROTECTIVE_STOP) == 2
    assert log.events[-1].details["reason"] == "controller protective stop"
    with pytest.raises(SafetyRefusal, match="teach pendant"):
        robot.move_to(CENTER, 0.1)
    assert arm.moves == []
    arm.protective_stop = False  # unlocked on the pendant
    robot.command_tcp_velocity(np.array([0.2, 0.0, 0.0]), 1.0)
    assert arm.commands[-1][0][0] == pytest.approx(0.05)  # ramps again from rest


def test_tracking_error_stops_the_arm_and_latches_until_reset() -> None:
    robot, arm, log = make()
    robot.command_tcp_velocity(np.array([0.1, 0.0, 0.0]), 1.0)
    assert robot.check_tracking(arm.position + [0.0, 0.0, 0.03])
    assert not robot.check_tracking(arm.position + [0.0, 0.0, 0.08])
    assert robot.stopped and len(arm.stops) == 1
    assert not robot.check_tracking(arm.position)  # latched
    assert len(arm.stops) == 1  # stopped once, not per check
    robot.command_tcp_velocity(np.array([0.1, 0.0, 0.0]), 1.0)
    assert len(arm.commands) == 1 and len(arm.stops) == 2
    with pytest.raises(SafetyRefusal, match="re-synchronise"):
        robot.move_to(CENTER, 0.1)
    robot.reset()
    assert not robot.stopped and robot.check_tracking(arm.position)
    robot.command_tcp_velocity(np.array([0.1, 0.0, 0.0]), 1.0)
    assert len(arm.commands) == 2
    counts = log.counts()
    assert counts[SafetyEventKind.TRACKING_ERROR] == 1 and counts[SafetyEventKind.STOP_CLEARED] == 1
    assert counts[SafetyEventKind.PROTECTIVE_STOP] == 2
    refusals = [e for e in log.events if e.kind is SafetyEventKind.PROTECTIVE_STOP]
    assert [e.details["what"] for e in refusals] == ["command_tcp_velocity", "move_to"]
    assert all(e.details["reason"] == "tracking-error stop latched" for e in refusals)


def test_move_to_is_clamped_into_the_box_and_speed_limited() -> None:
    robot, arm, log = make()
    robot.move_to(np.array([0.0, -0.45, 0.02]), speed=1.0)  # below the table, too fast
    target, speed = arm.moves[-1]
    np.testing.assert_allclose(target, [0.0, -0.45, LIMITS.low[2]])
    assert speed == LIMITS.max_speed
    assert log.count(SafetyEventKind.WORKSPACE_CLIPPED) == 1 and log.count(SafetyEventKind.SPEED_CLIPPED) == 1
    robot.move_to(CENTER, speed=0.1)  # inside, slow: untouched, no event
    np.testing.assert_allclose(arm.moves[-1][0], CENTER)
    assert arm.moves[-1][1] == 0.1 and len(log.events) == 2
    for target, speed in (([np.nan, 0.0, 0.2], 0.1), (CENTER, float("inf")), (CENTER, 0.0)):
        with pytest.raises(SafetyRefusal):
            robot.move_to(np.array(target), speed)
    assert len(arm.moves) == 2 and log.count(SafetyEventKind.NON_FINITE) == 3


def test_stop_is_never_gentler_than_the_braking_the_box_assumes() -> None:
    robot, arm, _ = make()
    robot.stop(0.01)
    robot.stop(float("nan"))
    robot.stop(5.0)
    assert arm.stops == [LIMITS.max_acceleration, LIMITS.max_acceleration, 5.0]


def test_random_driving_stays_in_the_box_within_the_limits() -> None:
    rng = np.random.default_rng(0)
    robot, arm, log = make()
    previous = np.zeros(3)
    for step in range(600):
        command = rng.normal(scale=0.5, size=3) if step % 50 else np.array([np.nan, 0.0, 0.0])
        robot.command_tcp_velocity(command, 1.0)
        velocity = arm.commands[-1][0]
        assert np.linalg.norm(velocity) <= LIMITS.max_speed + 1e-9
        assert np.linalg.norm(velocity - previous) <= LIMITS.max_acceleration * arm.control_period + 1e-9
        assert LIMITS.contains(arm.position)
        previous = velocity
    counts = log.counts()
    assert counts[SafetyEventKind.NON_FINITE] == 12
    assert counts[SafetyEventKind.SPEED_CLIPPED] > 0 and counts[SafetyEventKind.WORKSPACE_CLIPPED] > 0


def test_events_land_in_the_run_directory_jsonl(tmp_path: Path) -> None:
    with SafetyLog.in_run_dir(tmp_path) as log:
        robot, arm, _ = make(log=log)
        robot.command_tcp_velocity(np.array([3.0, 0.0, 0.0]), 1.0)  # speed + acceleration
        robot.command_tcp_velocity(np.array([np.inf, 0.0, 0.0]), 1.0)  # non-finite
        robot.check_tracking(arm.position + 1.0)  # tracking error
        robot.command_tcp_velocity(np.array([0.1, 0.0, 0.0]), 1.0)  # refused
        robot.reset()
        arm.protective_stop = True
        robot.command_tcp_velocity(np.array([0.1, 0.0, 0.0]), 1.0)  # refused
        arm.protective_stop = False
        robot.move_to([9.0, 9.0, 9.0], 0.1)  # clamped
    records = [json.loads(line) for line in (tmp_path / EVENTS_FILE).read_text().splitlines()]
    kinds = [r["kind"] for r in records]
    assert kinds == [
        "speed_clipped",
        "accel_clipped",
        "non_finite",
        "tracking_error",
        "protective_stop",
        "stop_cleared",
        "protective_stop",
        "workspace_clipped",
    ]
    assert records[2]["details"]["value"] == ["inf", 0.0, 0.0]
    assert records[3]["details"]["error"] == pytest.approx(np.sqrt(3.0), rel=1e-3)
    assert records[4]["robot_time"] == pytest.approx(2 * arm.control_period)
    assert len(records) == sum(log.counts().values())
