"""SafetyFilter: the guarantees hold for any input (hypothesis), and every trigger records its event."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from dpiil_rl.robots.interface import RobotState
from dpiil_rl.robots.safety_filter import SafetyFilter, braking_distance, braking_speed
from dpiil_rl.robots.safety_limits import SafetyLimits
from dpiil_rl.robots.safety_log import SafetyEventKind, SafetyLog

TOL = 1e-9  # m and m/s: rounding, far below anything physical

LIMITS = SafetyLimits(
    low=np.array([-0.3, -0.7, 0.05]),
    high=np.array([0.3, -0.25, 0.45]),
    max_speed=0.25,
    max_acceleration=1.0,
    max_tracking_error=0.05,
)
DT = 0.05


def state(position, time: float = 0.0) -> RobotState:
    return RobotState(
        tcp_position=np.asarray(position, dtype=np.float64),
        tcp_quaternion=np.array([1.0, 0, 0, 0]),
        tcp_velocity=np.zeros(3),
        joint_positions=np.zeros(6),
        time=time,
    )


def make_filter(limits: SafetyLimits = LIMITS) -> tuple[SafetyFilter, SafetyLog]:
    log = SafetyLog()
    return SafetyFilter(limits, log), log


# ------------------------------------------------------------------------------------------ braking bound
@settings(max_examples=200, deadline=None, database=None)
@given(
    distance=st.floats(0.0, 5.0),
    deceleration=st.floats(0.01, 50.0),
    dt=st.floats(1e-3, 0.5),
    cap=st.floats(1e-3, 5.0),
)
def test_braking_speed_is_the_tight_inverse_of_braking_distance(distance, deceleration, dt, cap) -> None:
    u = braking_speed(distance, deceleration, dt, cap)
    assert 0.0 <= u <= cap
    assert braking_distance(u, deceleration, dt) <= distance + 1e-12
    assert u**2 / (2 * deceleration) <= distance + 1e-12  # the continuous stopping distance fits too
    if u < cap:  # not capped: tight (no needless slowness)
        assert braking_distance(u, deceleration, dt) == pytest.approx(distance, rel=1e-9, abs=1e-12)
    # one step later, one step of braking brings the speed back under the bound (discrete consistency)
    later = braking_speed(distance - u * dt, deceleration, dt, cap)
    assert u - deceleration * dt <= later + 1e-12


# ------------------------------------------------------------------------------------------ property test
floats_any = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(-2.0, 2.0),
    st.sampled_from([0.0, 1e308, -1e308]),
)


@st.composite
def scenarios(draw):
    low = np.array(draw(st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3)))
    size = np.array(draw(st.lists(st.floats(0.01, 1.0), min_size=3, max_size=3)))
    limits = SafetyLimits(
        low=low,
        high=low + size,
        max_speed=draw(st.floats(0.01, 2.0)),
        max_acceleration=draw(st.floats(0.05, 20.0)),
    )
    position = np.empty(3)
    for axis in range(3):
        where = draw(st.sampled_from(["inside", "inside", "low wall", "high wall", "outside", "far"]))
        if where == "inside":
            fraction = draw(st.floats(0.0, 1.0))
        elif where == "low wall":
            fraction = 0.0
        elif where == "high wall":
            fraction = 1.0
        elif where == "outside":
            fraction = draw(st.one_of(st.floats(-0.5, 0.0), st.floats(1.0, 1.5)))
        else:
            fraction = draw(st.floats(-1e6, 1e6))
        position[axis] = limits.low[axis] + fraction * size[axis]
        if where in ("low wall", "high wall"):
            position[axis] = limits.low[axis] if where == "low wall" else limits.high[axis]
    velocity = np.array(draw(st.lists(floats_any, min_size=3, max_size=3)))
    previous = np.array(draw(st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3))) * limits.max_speed
    norm = np.linalg.norm(previous)
    if norm > limits.max_speed:  # a previous output always respects the speed limit
        previous *= limits.max_speed / norm
    dt = draw(st.floats(1e-3, 0.2))
    return limits, position, velocity, previous, dt


@settings(max_examples=300, deadline=None, database=None, suppress_health_check=[HealthCheck.too_slow])
@given(scenarios())
def test_guarantees_hold_for_any_input(scenario) -> None:
    limits, p, velocity, previous, dt = scenario
    filt, log = make_filter(limits)
    filt.reset(previous)
    v = filt.filter(velocity, state(p), dt)
    a = limits.max_acceleration

    assert v.shape == (3,) and np.all(np.isfinite(v))
    assert np.linalg.norm(v) <= limits.max_speed + TOL  # speed
    for axis in range(3):
        to_high = limits.high[axis] - p[axis]
        to_low = p[axis] - limits.low[axis]
        if to_high >= 0 and to_low >= 0:  # inside on this axis
            assert limits.low[axis] - TOL <= p[axis] + v[axis] * dt <= limits.high[axis] + TOL
            if v[axis] > 0:  # can stop before the wall
                assert v[axis] ** 2 / (2 * a) <= to_high + TOL
            if v[axis] < 0:
                assert v[axis] ** 2 / (2 * a) <= to_low + TOL
        elif to_high < 0:  # above the box: only back
            assert v[axis] <= 0.0
        else:
            assert v[axis] >= 0.0
    # acceleration: holds unless braking for a wall needs more (then exactly as much as needed)
    low, high = filt.velocity_bounds(p, dt)
    braking = np.linalg.norm(np.clip(previous, low, high) - previous)
    assert np.linalg.norm(v - previous) <= max(a * dt, braking) + TOL
    if braking == 0.0:
        assert np.linalg.norm(v - previous) <= a * dt + TOL
    if not np.all(np.isfinite(velocity)):  # non-finite: a stop, ramped
        assert log.count(SafetyEventKind.NON_FINITE) == 1
        assert np.linalg.norm(v) <= np.linalg.norm(previous) + TOL


@settings(max_examples=30, deadline=None, database=None)
@given(
    commands=st.lists(st.lists(floats_any, min_size=3, max_size=3), min_size=20, max_size=80),
    start=st.lists(st.floats(0.0, 1.0), min_size=3, max_size=3),
    dt=st.sampled_from([0.002, 0.01, 0.05, 0.1]),
)
def test_closed_loop_never_leaves_the_box_and_never_needs_the_braking_exception(commands, start, dt) -> None:
    """Box and acceleration are consistent: an arm that goes where it is sent never brakes beyond the limit."""
    filt, log = make_filter()
    p = LIMITS.low + np.array(start) * (LIMITS.high - LIMITS.low)
    previous = np.zeros(3)
    for command in commands:
        v = filt.filter(np.array(command), state(p), dt)
        assert np.linalg.norm(v) <= LIMITS.max_speed + TOL
        assert np.linalg.norm(v - previous) <= LIMITS.max_acceleration * dt + TOL
        p = p + v * dt
        assert np.all(p >= LIMITS.low - TOL) and np.all(p <= LIMITS.high + TOL)
        previous = v
    assert not any(e.details.get("beyond_acceleration") for e in log.events)


# ------------------------------------------------------------------------------------------ each trigger
def test_speed_is_clipped_and_reached_after_the_ramp() -> None:
    filt, log = make_filter()
    p = np.array([-0.3, -0.45, 0.25])  # at the low-x wall, heading +x: 0.6 m of room
    for _ in range(10):
        v = filt.filter([5.0, 0.0, 0.0], state(p), DT)
        p = p + v * DT
    assert np.linalg.norm(v) == pytest.approx(LIMITS.max_speed)
    assert log.count(SafetyEventKind.SPEED_CLIPPED) == 10
    assert log.events[0].details["requested"] == pytest.approx(5.0)


def test_a_step_command_is_ramped_at_max_acceleration() -> None:
    filt, log = make_filter()
    center = (LIMITS.low + LIMITS.high) / 2
    v = filt.filter([0.0, 0.2, 0.0], state(center), DT)
    np.testing.assert_allclose(v, [0.0, LIMITS.max_acceleration * DT, 0.0])
    v = filt.filter([0.0, 0.2, 0.0], state(center), DT)
    np.testing.assert_allclose(v, [0.0, 2 * LIMITS.max_acceleration * DT, 0.0])
    assert log.count(SafetyEventKind.ACCEL_CLIPPED) == 2
    assert log.count(SafetyEventKind.SPEED_CLIPPED) == 0 and log.count(SafetyEventKind.WORKSPACE_CLIPPED) == 0


def test_driving_into_a_wall_slows_down_and_stops_before_it() -> None:
    filt, log = make_filter()
    p = np.array([0.0, -0.45, 0.44])  # 1 cm below the ceiling of the box, pushing up at full speed
    for _ in range(40):
        v = filt.filter([0.0, 0.0, 0.25], state(p), DT)
        p = p + v * DT
        assert p[2] <= LIMITS.high[2]
    assert p[2] == pytest.approx(LIMITS.high[2], abs=1e-3) and abs(v[2]) < 1e-3
    assert log.count(SafetyEventKind.WORKSPACE_CLIPPED) >= 30


def test_a_fast_previous_command_at_a_wall_brakes_beyond_the_acceleration_limit() -> None:
    """The precedence rule: the box wins over the acceleration bound."""
    filt, log = make_filter()
    filt.reset([0.25, 0.0, 0.0])  # moving +x at full speed ...
    p = np.array([LIMITS.high[0] - 0.001, -0.45, 0.25])  # ... 1 mm before the wall
    v = filt.filter([0.25, 0.0, 0.0], state(p), DT)
    assert p[0] + v[0] * DT <= LIMITS.high[0]
    assert 0.25 - v[0] > LIMITS.max_acceleration * DT
    event = next(e for e in log.events if e.kind is SafetyEventKind.WORKSPACE_CLIPPED)
    assert event.details["braking"] and event.details["beyond_acceleration"]


def test_outside_the_box_only_the_way_back_is_allowed() -> None:
    filt, log = make_filter()
    p = np.array([0.5, -0.45, 0.25])  # 20 cm beyond the high-x wall
    for _ in range(5):
        v = filt.filter([0.2, 0.1, 0.0], state(p), DT)  # pushing further out (x), sideways (y)
        assert v[0] <= 0.0
    assert v[1] > 0.0  # sideways is not away from the box
    assert log.count(SafetyEventKind.WORKSPACE_CLIPPED) == 5
    for _ in range(10):
        v = filt.filter([-0.2, 0.0, 0.0], state(p), DT)  # back toward the box: allowed
        p = p + v * DT
    assert v[0] < -0.1 and p[0] < 0.5


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_command_is_a_ramped_stop_and_an_event(bad: float) -> None:
    filt, log = make_filter()
    center = (LIMITS.low + LIMITS.high) / 2
    filt.reset([0.2, 0.0, 0.0])
    v = filt.filter([bad, 0.0, 0.0], state(center), DT)
    np.testing.assert_allclose(v, [0.2 - LIMITS.max_acceleration * DT, 0.0, 0.0])
    for _ in range(10):
        v = filt.filter([0.0, bad, 0.1], state(center), DT)
    np.testing.assert_allclose(v, 0.0)
    assert log.count(SafetyEventKind.NON_FINITE) == 11
    assert log.events[0].details["what"] == "velocity"


def test_non_finite_position_commands_zero_at_once() -> None:
    filt, log = make_filter()
    filt.reset([0.2, 0.0, 0.0])
    v = filt.filter([0.2, 0.0, 0.0], state([np.nan, 0.0, 0.3]), DT)
    np.testing.assert_array_equal(v, 0.0)
    assert log.count(SafetyEventKind.NON_FINITE) == 1 and log.events[0].details["what"] == "tcp_position"
    np.testing.assert_array_equal(filt.previous, 0.0)


def test_tracking_error_latches_a_stop_until_reset() -> None:
    filt, log = make_filter()
    center = (LIMITS.low + LIMITS.high) / 2
    assert filt.check_tracking(center + [0.0, 0.04, 0.0], state(center))
    assert not filt.check_tracking(center + [0.0, 0.06, 0.0], state(center, time=3.0))
    assert filt.stopped
    assert not filt.check_tracking(center, state(center))  # back on target: still latched
    assert log.count(SafetyEventKind.TRACKING_ERROR) == 1
    event = log.events[-1]
    assert event.details["error"] == pytest.approx(0.06) and event.robot_time == 3.0
    filt.reset()  # the person re-synchronised
    assert not filt.stopped and log.count(SafetyEventKind.STOP_CLEARED) == 1
    assert filt.check_tracking(center, state(center))
    filt.reset()  # nothing latched: no event
    assert log.count(SafetyEventKind.STOP_CLEARED) == 1


def test_latched_stop_commands_a_ramp_to_zero() -> None:
    filt, _ = make_filter()
    center = (LIMITS.low + LIMITS.high) / 2
    filt.reset([0.2, 0.0, 0.0])
    filt.check_tracking(center + [0.1, 0.0, 0.0], state(center))
    v = filt.filter([0.2, 0.0, 0.0], state(center), DT)
    np.testing.assert_allclose(v, [0.2 - LIMITS.max_acceleration * DT, 0.0, 0.0])
    for _ in range(5):
        v = filt.filter([0.2, 0.0, 0.0], state(center), DT)
    np.testing.assert_allclose(v, 0.0)


def test_non_finite_tracking_target_latches_too() -> None:
    filt, log = make_filter()
    center = (LIMITS.low + LIMITS.high) / 2
    assert not filt.check_tracking([np.nan, 0.0, 0.0], state(center))
    assert filt.stopped and log.count(SafetyEventKind.NON_FINITE) == 1


@pytest.mark.parametrize("dt", [0.0, -0.05, math.nan, math.inf])
def test_bad_dt_is_a_programming_error(dt: float) -> None:
    filt, _ = make_filter()
    with pytest.raises(ValueError, match="dt="):
        filt.filter([0.0, 0.0, 0.0], state([0.0, -0.45, 0.25]), dt)
