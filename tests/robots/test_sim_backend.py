"""The simulated UR5e backend on real MuJoCo simulations (no mocks): velocity tracking, resets, contacts."""

import subprocess
import sys

import numpy as np
import pytest

from dpiil_rl.robots.sim_backend import SimUR5eBackend
from dpiil_rl.robots.sim_scene import Scene, quat_to_matrix
from tests.conftest import ROOT

SCENE = {
    "table": {"size": [0.45, 0.6, 0.02], "pos": [0.30, 0.0, -0.02]},
    "objects": {
        "post": {"shape": "cylinder", "size": [0.02, 0.10], "pos": [0.45, 0.25, 0.10], "role": "target"},
        "wall": {"shape": "box", "size": [0.01, 0.10, 0.10], "pos": [0.55, -0.15, 0.10]},
    },
    "held": {"rod": {"shape": "capsule", "size": [0.005, 0.04], "pos": [0.0, 0.0, -0.05]}},  # a pin 5 cm below the TCP
}
START = np.array([0.35, -0.15, 0.25])


@pytest.fixture(scope="module")
def robot():
    with SimUR5eBackend(SCENE) as backend:
        yield backend


def _angle(q1: np.ndarray, q2: np.ndarray) -> float:
    return float(2 * np.arccos(min(1.0, abs(float(np.dot(q1, q2))))))


def test_importing_the_backend_loads_neither_robosuite_nor_mujoco():
    code = (
        "import sys, dpiil_rl.robots.sim_backend, dpiil_rl.robots.sim_scene\n"
        "bad = [m for m in sys.modules if m.split('.')[0] in ('robosuite', 'mujoco')]\n"
        "assert not bad, bad\n"
    )
    subprocess.run([sys.executable, "-c", code], cwd=ROOT, check=True)


def test_move_to_reaches_the_position_with_the_held_orientation_reproducibly(robot):
    robot.move_to(START, 0.25)
    first = robot.read_state()
    robot.move_to(START + [0.05, 0.0, -0.05], 0.25)
    robot.move_to(START, 0.25)
    second = robot.read_state()
    assert np.allclose(first.tcp_position, START, atol=1e-3)
    assert np.array_equal(
        first.joint_positions, second.joint_positions
    )  # same target, same joints: reproducible starts
    tool = quat_to_matrix(first.tcp_quaternion)
    assert np.allclose(tool[:, 2], [0.0, 0.0, -1.0], atol=1e-3)  # the configured tool orientation: pointing down
    assert not first.collision and np.allclose(first.tcp_velocity, 0.0, atol=1e-3)


def test_tracks_a_commanded_velocity_and_holds_orientation(robot):
    robot.move_to(START, 0.25)
    q0 = robot.read_state().tcp_quaternion
    command = np.array([0.10, 0.08, -0.06])
    for _ in range(5):  # accelerate (2 m/s^2: 0.14 m/s within 2 periods)
        robot.command_tcp_velocity(command, 2.0)
    p0, t0 = robot.read_state().tcp_position, robot.read_state().time
    for _ in range(15):
        robot.command_tcp_velocity(command, 2.0)
    state = robot.read_state()
    assert state.time - t0 == pytest.approx(15 * robot.control_period)
    assert np.allclose(state.tcp_position - p0, command * 15 * robot.control_period, atol=2e-3)
    assert np.allclose(state.tcp_velocity, command, atol=5e-3)
    assert _angle(state.tcp_quaternion, q0) < np.radians(0.5)
    robot.stop(2.0)
    assert np.linalg.norm(robot.read_state().tcp_velocity) < 5e-3


def test_acceleration_bounds_the_change_of_velocity(robot):
    robot.move_to(START, 0.25)
    robot.command_tcp_velocity(np.array([0.2, 0.0, 0.0]), 1.0)  # 1 m/s^2 over 0.05 s: at most 0.05 m/s
    assert robot.read_state().tcp_velocity[0] == pytest.approx(0.05, abs=5e-3)


def _drive_until_contact(robot, velocity, periods=60):
    for _ in range(periods):
        robot.command_tcp_velocity(np.asarray(velocity), 2.0)
        if robot.read_state().collision:
            return set(robot.contact_pairs())
    return set()


def test_contacts_with_the_scene_and_the_table_are_collisions(robot):
    robot.move_to(np.array([0.45, -0.15, 0.25]), 0.25)  # in front of the wall (x 0.54 to 0.56, up to z = 0.2)
    assert not robot.read_state().collision
    free = _drive_until_contact(robot, [0.0, 0.1, 0.0], periods=10)  # sideways, clear of everything
    assert free == set() and not robot.read_state().collision
    robot.move_to(np.array([0.45, -0.15, 0.25]), 0.25)
    pairs = _drive_until_contact(robot, [0.1, 0.0, 0.0])  # the held pin (down to z = 0.155) runs into the wall
    assert ("held_object", "scene_wall") in pairs, pairs
    robot.move_to(np.array([0.3, 0.1, 0.12]), 0.25)
    assert not robot.read_state().collision
    pairs = _drive_until_contact(
        robot, [0.0, 0.0, -0.1]
    )  # straight down: the pin (9.5 cm below the TCP) meets the table
    assert ("held_object", "scene_table") in pairs, pairs
    assert robot.read_state().tcp_position[2] > 0.08  # stopped by the pin, long before the fingertips


def test_unreachable_start_and_bad_settings_name_the_value(robot):
    with pytest.raises(ValueError, match="tcp_position = "):
        robot.move_to(np.array([1.5, 0.0, 0.2]), 0.25)
    with pytest.raises(ValueError, match="robot.timestep = 0.003"):
        SimUR5eBackend(SCENE, timestep=0.003)
    with pytest.raises(ValueError, match="shape = 'cone'"):
        Scene.from_mapping(
            {**SCENE, "objects": {"x": {"shape": "cone", "size": [1], "pos": [0, 0, 0], "role": "target"}}}
        )
    with pytest.raises(ValueError, match="expected exactly one"):
        Scene.from_mapping({**SCENE, "objects": {}})
