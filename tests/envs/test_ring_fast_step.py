"""The compiled ring step (:class:`~dpiil_rl.envs.ring_fast_step.FastStep`) against robosuite's own ``env.step``.

- torques: from the same MuJoCo state and the same 7-D command, the law gives robosuite's OSC_POSE torques
  (and the same ``ctrl``, gripper included), at a policy substep and the substeps after it, on the first step
  after a reset (robosuite's cached controller state) and later;
- free motion: from the same seed and actions, the robot's and the ring's qpos / qvel, the observations and
  the flags stay with robosuite's over 200 steps with the arm in free space;
- contact (``-m slow``): scripted-expert episodes succeed as often and take as long with either step; the
  100-episode comparison is ``make bench`` (``bench/ring_benchmarks.py``, ``fast_step_agreement``).
"""

from __future__ import annotations

import numpy as np
import pytest
import torch
from tensordict.nn import TensorDictSequential

from dpiil_rl.collectors.expert_switch import ExpertSwitch
from dpiil_rl.collectors.intervention import InterventionCollector, run_episodes
from dpiil_rl.envs.ring_task import RingGeometry
from dpiil_rl.modules.gate import ConstantGate
from dpiil_rl.training.factory import build_env, make_expert
from tests.conftest import ROOT, load_config, plain

TORQUE_TOLERANCE = 1e-9  # N m: the law against robosuite's controller on one state
STATE_TOLERANCE = 1e-5  # rad, m, rad/s, m/s: the two simulations after 200 free steps
FREE_STEPS = 200


def _ring_cfg():
    return load_config(ROOT / "configs" / "env" / "ring.yaml")


def _geometry() -> RingGeometry:
    spec = plain(_ring_cfg(), resolve=True)
    for key in ("_target_", "name", "workers", "sim", "expert"):
        spec.pop(key)
    return RingGeometry.from_mapping(spec)


def _sim(fast_step: bool):
    from dpiil_rl.envs.ring_sim import RingSim, RingSimSettings

    return RingSim(_geometry(), RingSimSettings(fast_step=fast_step))


def _free_actions(steps: int) -> np.ndarray:
    """6-D actions that wander the gripper (open) around its start above the table, touching nothing."""
    t = np.arange(steps)[:, None]
    wave = np.sin(2 * np.pi * t / np.array([47.0, 61.0, 37.0, 53.0, 71.0]) + np.array([0.0, 1.0, 2.0, 0.5, 1.5]))
    actions = np.concatenate([0.4 * wave[:, :3], 0.3 * wave[:, 3:], -np.ones((steps, 1))], axis=1)
    actions[:, 2] += 0.05  # drift up: away from the table and the ring
    return actions


def _robot_and_ring(sim) -> np.ndarray:
    """qpos and qvel of the robot's joints (arm and gripper) and of the ring's free joint."""
    data, robot = sim.env.sim.data, sim.env.robots[0]
    joints = list(robot.robot_model.joints) + list(robot.gripper[robot.arms[0]].joints) + [sim._ring_joint]
    return np.concatenate(
        [np.atleast_1d(data.get_joint_qpos(j)) for j in joints]
        + [np.atleast_1d(data.get_joint_qvel(j)) for j in joints]
    )


# ------------------------------------------------------------------------------------------------ torques
@pytest.fixture(scope="module")
def robosuite_sim():
    sim = _sim(fast_step=False)
    yield sim
    sim.close()


def _compare_substep(sim, fast, command: np.ndarray, policy_step: bool) -> tuple[float, float]:
    """(torque, ctrl) max differences: robosuite's ``robot.control`` vs the law on the state after ``mj_step1``."""
    env = sim.env
    robot = env.robots[0]
    arm = robot.composite_controller.part_controllers[robot.arms[0]]
    gripper = robot.gripper[robot.arms[0]]
    fresh, gripper_action = arm.new_update, np.array(gripper.current_action)
    robot.control(command, policy_step=policy_step)
    torques, ctrl = np.array(arm.torques), np.array(env.sim.data.ctrl)
    arm.new_update, gripper.current_action = fresh, gripper_action  # the law sees what robosuite saw
    ours = fast.control(command, policy_step=policy_step)
    return float(np.abs(ours - torques).max()), float(np.abs(np.asarray(env.sim.data.ctrl) - ctrl).max())


def _worst_over_a_step(sim, fast, command: np.ndarray, substeps: int = 4) -> tuple[float, ...]:
    worst: tuple[float, ...] = (0.0, 0.0)
    for k in range(substeps):
        sim.env.sim.step1()
        worst = tuple(max(w, d) for w, d in zip(worst, _compare_substep(sim, fast, command, policy_step=k == 0)))
        sim.env.sim.step2()
    return worst


def test_torques_equal_robosuite_controller_on_the_same_state(robosuite_sim):
    from dpiil_rl.envs.ring_fast_step import FastStep

    sim = robosuite_sim
    fast = FastStep(sim.env)
    rng = np.random.default_rng(0)
    sim.reset(17)
    # the first step after a reset: robosuite's controller still holds the state it cached when it was built
    assert not sim.env.robots[0].composite_controller.part_controllers["right"].new_update
    first = _worst_over_a_step(sim, fast, np.array([0.4, -0.3, 0.2, 0.1, -0.2, 0.3, -1.0]))
    for action in _free_actions(30):  # a moving arm: velocities, a goal away from the pose
        sim.step(action)
    later = [_worst_over_a_step(sim, fast, np.clip(rng.normal(0.0, 0.5, 7), -1, 1)) for _ in range(3)]
    worst_torque = max([first[0]] + [w[0] for w in later])
    worst_ctrl = max([first[1]] + [w[1] for w in later])
    assert worst_torque < TORQUE_TOLERANCE, (first, later)
    assert worst_ctrl < TORQUE_TOLERANCE, (first, later)


def test_goal_equals_robosuite_goal(robosuite_sim):
    from dpiil_rl.envs.ring_fast_step import FastStep

    sim = robosuite_sim
    fast = FastStep(sim.env)
    sim.reset(5)
    for action in _free_actions(10):
        sim.step(action)
    arm = sim.env.robots[0].composite_controller.part_controllers["right"]
    sim.env.sim.step1()
    command = np.array([1.5, -0.7, 0.3, 0.9, -0.4, 0.2, 1.0])  # |a| > 1: the input clip is part of the law
    _compare_substep(sim, fast, command, policy_step=True)
    assert np.abs(fast._state.goal_pos - arm.goal_pos).max() < 1e-12
    assert np.abs(fast._state.goal_ori - arm.goal_ori).max() < 1e-12


# ------------------------------------------------------------------------------------------------ free motion
def test_free_motion_stays_with_robosuite_for_200_steps():
    ours, theirs = _sim(fast_step=True), _sim(fast_step=False)
    try:
        a, b = ours.reset(3), theirs.reset(3)
        assert np.array_equal(a["observation"], b["observation"])
        worst_state = worst_obs = 0.0
        ring_start = np.array(theirs.env.sim.data.get_joint_qpos(theirs._ring_joint)[:3])
        for action in _free_actions(FREE_STEPS):
            a, b = ours.step(action), theirs.step(action)
            worst_state = max(worst_state, float(np.abs(_robot_and_ring(ours) - _robot_and_ring(theirs)).max()))
            worst_obs = max(worst_obs, float(np.abs(a["observation"] - b["observation"]).max()))
            assert bool(a["success"]) == bool(b["success"]) and bool(a["collision"]) == bool(b["collision"])
            assert not bool(b["collision"])  # free space: no robot-table / robot-peg contact
        ring_end = np.array(theirs.env.sim.data.get_joint_qpos(theirs._ring_joint)[:3])
        assert np.abs(ring_end - ring_start).max() < 1e-3  # the arm never touched the ring
        assert worst_state < STATE_TOLERANCE, worst_state
        assert worst_obs < STATE_TOLERANCE, worst_obs
        assert ours.env.timestep == theirs.env.timestep == FREE_STEPS
        assert ours.env.cur_time == theirs.env.cur_time
        for name, observable in theirs.env._observables.items():  # robosuite's observable timers, replayed
            mine = ours.env._observables[name]
            assert (mine._time_since_last_sample, mine._sampled) == (
                observable._time_since_last_sample,
                observable._sampled,
            )
        robot_a, robot_b = ours.env.robots[0], theirs.env.robots[0]
        assert np.abs(robot_a.recent_ee_acc["right"].current - robot_b.recent_ee_acc["right"].current).max() < 1e-6
        assert np.abs(robot_a.recent_ee_pose["right"].current - robot_b.recent_ee_pose["right"].current).max() < 1e-6
    finally:
        ours.close()
        theirs.close()


def test_bad_fast_step_setting_is_one_clear_error():
    from dpiil_rl.envs.ring_sim import RingSimSettings

    with pytest.raises(ValueError, match=r"env.sim.fast_step = 'yes': expected true or false"):
        RingSimSettings(fast_step="yes")  # type: ignore[arg-type]


# ------------------------------------------------------------------------------------------------ contact
def _expert_episodes(fast_step: bool, episodes: int, seed: int) -> list[dict]:
    cfg = _ring_cfg()
    cfg.sim.fast_step = fast_step
    cfg.workers = 2
    env = build_env(cfg, 2, seed=seed)
    expert = make_expert(load_config(ROOT / "configs" / "expert" / "scripted.yaml"), env, seed)
    collector = InterventionCollector(
        env, TensorDictSequential([ConstantGate(True), ExpertSwitch(expert)]), expert=expert
    )
    try:
        with torch.no_grad():
            return [e.record for e in run_episodes(collector, episodes, "demo", 0)]
    finally:
        env.close()


@pytest.mark.slow
def test_scripted_expert_episodes_agree_with_robosuite():
    episodes = 6
    ours, theirs = _expert_episodes(True, episodes, 4_242), _expert_episodes(False, episodes, 4_242)
    wins = [sum(r["success"] for r in rows) for rows in (ours, theirs)]
    lengths = [float(np.mean([r["length"] for r in rows])) for rows in (ours, theirs)]
    assert abs(wins[0] - wins[1]) <= 2, (wins, lengths)  # the expert threads ~99 of 100 either way (make bench)
    assert abs(lengths[0] - lengths[1]) < 0.15 * lengths[1], (wins, lengths)
