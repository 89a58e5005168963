"""The ring simulation's control step without robosuite's per-substep Python: ``FastStep(env).step(action)``.

A drop-in for robosuite 1.5.2's ``MujocoEnv.step`` on an env with one fixed-base, one-arm robot driven by the
BASIC composite controller with an OSC_POSE arm (delta input, base frame, fixed impedance, no
interpolators) and a ``SimpleGripController`` gripper (the ring's UR5e + Robotiq85). It returns what
``env.step`` returns and leaves the env, the robot, its controllers and the observables as ``env.step`` would:

1. ``timestep`` + 1; the gripper command: the gripper model's own ``format_action``, then the
   ``SimpleGripController`` law (``scale_action``, ``bias + weight * goal``) once (it does not depend on the
   state, so robosuite's 25 identical evaluations are one), clipped to the actuators' ``ctrlrange``
   (``FixedBaseRobot.control``);
2. the substeps ``int(control_timestep / model_timestep)`` of ``mj_step1`` -> OSC_POSE torques from the
   state -> ``mj_step2``, compiled (:func:`dpiil_rl.envs.osc_law.run_substeps`, calling MuJoCo's C functions
   :mod:`dpiil_rl.envs.mujoco_c`), the goal set at the first; the loop pauses after a substep at which an
   observable samples, to sample it as robosuite would (:mod:`dpiil_rl.envs.observable_schedule`);
3. what ``FixedBaseRobot.control`` records on a policy step (recent joints, action, torques, eef
   force-torque, pose, velocity, acceleration), the controllers' state of the last substep, then
   ``cur_time``, ``_post_action`` (reward, ``_check_success``, done) and ``_get_observations``
   (:meth:`FastStep.advance` is the step without that last dict: the observables hold the values).

robosuite still builds the model and the scene and resets the env; it builds new controllers at every reset,
which :meth:`FastStep.step` notices and reads again (gains, limits, indices: nothing is copied by hand).
Configurations the compiled law does not cover are refused with a message naming the setting. Building a
``FastStep`` loads (or, the first time, compiles) the compiled loop, so no step pays for it.
"""

from __future__ import annotations

import inspect
from dataclasses import dataclass
from typing import Any, NoReturn, cast

import numpy as np

from dpiil_rl.envs.mujoco_c import load_mujoco_c
from dpiil_rl.envs.observable_schedule import finish, sample, sampling_plan

ROBOSUITE_VERSION = "1.5.2"  # the robosuite whose step this reproduces (its private attributes included)


def _refuse(setting: str, value: Any, expected: str) -> NoReturn:
    raise ValueError(
        f"fast step: {setting} = {value!r}: expected {expected} (set env.sim.fast_step: false to step with robosuite)"
    )


@dataclass
class _Law:
    """Everything the compiled law reads from one set of robosuite controllers (rebuilt at every reset)."""

    composite: Any  # the robot's CompositeController these values come from
    arm: Any  # OperationalSpaceController
    gripper: Any  # SimpleGripController
    gripper_model: Any  # the gripper model (format_action)
    arm_slice: slice  # the arm's part of the robot action
    gripper_slice: slice  # the gripper's part of the robot action
    grip_site: int  # the controller's reference site (grip site)
    base_site: int  # the arm's base site ({prefix}{part}_center)
    qpos_index: np.ndarray  # arm joints in qpos
    qvel_index: np.ndarray  # arm joints in qvel
    arm_actuators: np.ndarray
    gripper_actuators: np.ndarray
    ctrl_min: np.ndarray  # arm actuators' ctrlrange (FixedBaseRobot.control clips to it)
    ctrl_max: np.ndarray
    gripper_ctrl_min: np.ndarray
    gripper_ctrl_max: np.ndarray
    gripper_in_min: np.ndarray  # SimpleGripController.scale_action and run_controller
    gripper_in_max: np.ndarray
    gripper_in_mid: np.ndarray
    gripper_scale: np.ndarray
    gripper_out_mid: np.ndarray
    gripper_bias: np.ndarray  # centre and half-width of the gripper controller's actuator range
    gripper_weight: np.ndarray
    kp: np.ndarray
    kd: np.ndarray
    null_kp: float  # nullspace_torques' joint_kp (robosuite calls it with its default)
    uncoupled: bool  # uncouple_pos_ori
    in_min: np.ndarray  # Controller.scale_action: clip range, centres and scale
    in_max: np.ndarray
    in_mid: np.ndarray
    scale: np.ndarray
    out_mid: np.ndarray
    force_sensor: slice  # the eef force / torque sensors in sensordata (recent_ee_forcetorques)
    torque_sensor: slice


def _scaling(controller: Any) -> tuple[np.ndarray, ...]:
    """``Controller.scale_action``'s clip range and affine map: ``(in_min, in_max, in_mid, scale, out_mid)``
    (robosuite computes them at the first call; the same formula here, or its values once it has)."""
    in_min, in_max = np.asarray(controller.input_min, float), np.asarray(controller.input_max, float)
    out_min, out_max = np.asarray(controller.output_min, float), np.asarray(controller.output_max, float)
    if controller.action_scale is None:
        scale = np.abs(out_max - out_min) / np.abs(in_max - in_min)
        out_mid, in_mid = (out_max + out_min) / 2.0, (in_max + in_min) / 2.0
    else:
        scale, out_mid, in_mid = (
            controller.action_scale,
            controller.action_output_transform,
            controller.action_input_transform,
        )
    return tuple(np.ascontiguousarray(v, dtype=np.float64) for v in (in_min, in_max, in_mid, scale, out_mid))


class FastStep:
    """``step(action) -> (observations, reward, done, info)`` of a robosuite env, as ``env.step`` but compiled."""

    def __init__(self, env: Any) -> None:
        import robosuite  # noqa: PLC0415
        import robosuite.macros as macros  # noqa: PLC0415

        if robosuite.__version__ != ROBOSUITE_VERSION:
            _refuse("robosuite version", robosuite.__version__, ROBOSUITE_VERSION)
        if not macros.ENABLE_NUMBA:
            _refuse(
                "robosuite.macros.ENABLE_NUMBA",
                macros.ENABLE_NUMBA,
                "True (the law calls robosuite's compiled functions)",
            )
        if not env.lite_physics:
            _refuse("lite_physics", env.lite_physics, "True (mj_step1 / controllers / mj_step2 substeps)")
        if len(env.robots) != 1:
            _refuse("robots", len(env.robots), "one robot")
        from dpiil_rl.envs import osc_law  # noqa: PLC0415  (numba, robosuite's compiled helpers)

        self._substeps, self._control = osc_law.run_substeps, osc_law.control
        self._c = load_mujoco_c()
        self.env = env
        self._sim: Any = None
        self._law: _Law | None = None
        law = self._current_law()  # controllers exist from robosuite.make on (it resets the env)
        self.substeps(law, 0, False, False, np.zeros(law.in_min.shape[0]), np.zeros(law.gripper_actuators.shape[0]))

    # ------------------------------------------------------------------------------------------ binding
    def _bind_sim(self) -> None:
        """MuJoCo model, data and the work buffers (again after a hard reset rebuilt the simulation)."""
        sim = self.env.sim
        m, d = sim.model._model, sim.data._data
        nv = m.nv
        self._sim = sim
        self._addr = (m._address, d._address)
        self._data = (d.qpos, d.qvel, d.qM, d.qfrc_bias, d.site_xpos, d.site_xmat, d.ctrl)
        self._sensordata = d.sensordata
        self._jac = [np.zeros((3, nv)) for _ in range(4)]  # grip site jacp, jacr; base site jacp, jacr
        self._full_m = np.zeros((nv, nv))
        self._first_sensordata = np.zeros(m.nsensordata)
        self._law = None
        self._gripper_ctrl = np.zeros(0)

    def _bind_law(self) -> _Law:
        """Read the law from the robot's current controllers (robosuite builds new ones at every reset)."""
        from robosuite.controllers.composite.composite_controller import CompositeController  # noqa: PLC0415
        from robosuite.controllers.parts.arm.osc import OperationalSpaceController  # noqa: PLC0415
        from robosuite.controllers.parts.gripper.simple_grip import SimpleGripController  # noqa: PLC0415
        from robosuite.robots.fixed_base_robot import FixedBaseRobot  # noqa: PLC0415
        from robosuite.utils.control_utils import nullspace_torques  # noqa: PLC0415

        robot = self.env.robots[0]
        composite = robot.composite_controller
        model = self.env.sim.model
        if not isinstance(robot, FixedBaseRobot):
            _refuse("robot", type(robot).__name__, "a FixedBaseRobot")
        if type(composite) is not CompositeController:
            _refuse("composite controller", type(composite).__name__, "robosuite's BASIC CompositeController")
        if len(robot.arms) != 1:
            _refuse("arms", list(robot.arms), "one arm")
        arm_name = robot.arms[0]
        gripper_name = robot.get_gripper_name(arm_name)
        if list(composite.part_controllers) != [arm_name, gripper_name]:
            _refuse("controller parts", list(composite.part_controllers), f"[{arm_name!r}, {gripper_name!r}]")
        arm, gripper = composite.part_controllers[arm_name], composite.part_controllers[gripper_name]
        if type(arm) is not OperationalSpaceController:
            _refuse("arm controller", type(arm).__name__, "OperationalSpaceController (OSC_POSE)")
        for setting, value, expected in (
            ("use_ori", arm.use_ori, True),
            ("input_type", arm.input_type, "delta"),
            ("input_ref_frame", arm.input_ref_frame, "base"),
            ("impedance_mode", arm.impedance_mode, "fixed"),
            ("interpolator_pos", arm.interpolator_pos, None),
            ("interpolator_ori", arm.interpolator_ori, None),
            ("position_limits", arm.position_limits, None),
            ("orientation_limits", arm.orientation_limits, None),
            ("goal update mode", arm._goal_update_mode, "achieved"),
            ("controller lite_physics", arm.lite_physics, True),
        ):
            if value is not expected and value != expected:
                _refuse(f"OSC {setting}", value, repr(expected))
        if type(gripper) is not SimpleGripController:
            _refuse("gripper controller", type(gripper).__name__, "SimpleGripController")
        if gripper.interpolator is not None:
            _refuse("gripper interpolator", gripper.interpolator, "None")
        if not all(robot.enabled(part) for part in (arm_name, gripper_name)):
            _refuse("enabled parts", robot._enabled_parts, "arm and gripper enabled")
        split = composite._action_split_indexes
        actuators = robot._ref_actuators_indexes_dict
        ctrlrange = np.asarray(model.actuator_ctrlrange)
        in_min, in_max, in_mid, scale, out_mid = _scaling(arm)
        g_in_min, g_in_max, g_in_mid, g_scale, g_out_mid = _scaling(gripper)
        g_low, g_high = np.asarray(gripper.actuator_min, float), np.asarray(gripper.actuator_max, float)
        # robosuite is untyped: read from its source, its robots' gripper dict holds None
        sensors = cast(Any, robot.gripper[arm_name]).important_sensors

        def sensor_slice(name: str) -> slice:  # Robot.get_sensor_measurement
            sid = model.sensor_name2id(name)
            start = int(np.sum(model.sensor_dim[:sid]))
            return slice(start, start + int(model.sensor_dim[sid]))

        def as_index(values: Any) -> np.ndarray:
            return np.ascontiguousarray(values, dtype=np.int64)

        def as_float(values: Any) -> np.ndarray:
            return np.ascontiguousarray(values, dtype=np.float64)

        arm_actuators, gripper_actuators = as_index(actuators[arm_name]), as_index(actuators[gripper_name])
        return _Law(
            composite=composite,
            arm=arm,
            gripper=gripper,
            gripper_model=composite.grippers[gripper_name],
            arm_slice=slice(*split[arm_name]),
            gripper_slice=slice(*split[gripper_name]),
            grip_site=int(model.site_name2id(arm.ref_name)),
            base_site=int(model.site_name2id(f"{arm.naming_prefix}{arm.part_name}_center")),
            qpos_index=as_index(arm.qpos_index),
            qvel_index=as_index(arm.qvel_index),
            arm_actuators=arm_actuators,
            gripper_actuators=gripper_actuators,
            ctrl_min=as_float(ctrlrange[arm_actuators, 0]),
            ctrl_max=as_float(ctrlrange[arm_actuators, 1]),
            gripper_ctrl_min=as_float(ctrlrange[gripper_actuators, 0]),
            gripper_ctrl_max=as_float(ctrlrange[gripper_actuators, 1]),
            gripper_in_min=g_in_min,
            gripper_in_max=g_in_max,
            gripper_in_mid=g_in_mid,
            gripper_scale=g_scale,
            gripper_out_mid=g_out_mid,
            gripper_bias=0.5 * (g_high + g_low),
            gripper_weight=0.5 * (g_high - g_low),
            kp=as_float(arm.kp),
            kd=as_float(arm.kd),
            null_kp=float(inspect.signature(nullspace_torques.py_func).parameters["joint_kp"].default),
            uncoupled=bool(arm.uncoupling),
            in_min=in_min,
            in_max=in_max,
            in_mid=in_mid,
            scale=scale,
            out_mid=out_mid,
            force_sensor=sensor_slice(sensors["force_ee"]),
            torque_sensor=sensor_slice(sensors["torque_ee"]),
        )

    def _current_law(self) -> _Law:
        if self._sim is not self.env.sim:
            self._bind_sim()
        if self._law is None or self._law.composite is not self.env.robots[0].composite_controller:
            self._law = self._bind_law()
            self._state = _ArmState(self._law.qvel_index.shape[0])
        return self._law

    # ------------------------------------------------------------------------------------------ the step
    def gripper_ctrl(self, law: _Law, command: np.ndarray) -> np.ndarray:
        """The gripper actuators' ctrl for this control step: the gripper model's ``format_action`` (robosuite's
        own, it keeps the gripper's state), then ``SimpleGripController.set_goal`` (``scale_action``) and
        ``run_controller`` (``bias + weight * goal`` over the actuators' range) and ``FixedBaseRobot.control``'s
        clip; the controller is left with the goal and output robosuite's would hold."""
        gripper = law.gripper
        goal = law.gripper_model.format_action(command)
        if gripper.use_action_scaling:
            goal = (
                np.clip(goal, law.gripper_in_min, law.gripper_in_max) - law.gripper_in_mid
            ) * law.gripper_scale + law.gripper_out_mid
        gripper.goal_qvel = goal
        gripper.vels = law.gripper_bias + law.gripper_weight * goal if gripper.use_action_scaling else np.array(goal)
        gripper.new_update = True
        return np.clip(gripper.vels, law.gripper_ctrl_min, law.gripper_ctrl_max)

    def _control_args(
        self, law: _Law, policy_step: bool, cached_state: bool, command: np.ndarray, gripper_ctrl: np.ndarray
    ) -> tuple[Any, ...]:
        """The arguments of :func:`dpiil_rl.envs.osc_law.control` (``run_substeps`` passes them on)."""
        c, s = self._c, self._state
        return (
            c.mj_jacSite,
            c.mj_fullM,
            *self._addr,
            *self._data,
            policy_step,
            cached_state,
            command,
            law.grip_site,
            law.base_site,
            law.qpos_index,
            law.qvel_index,
            law.arm_actuators,
            law.gripper_actuators,
            gripper_ctrl,
            law.ctrl_min,
            law.ctrl_max,
            law.kp,
            law.kd,
            law.null_kp,
            law.uncoupled,
            np.ascontiguousarray(law.arm.initial_joint, dtype=np.float64),
            law.in_min,
            law.in_max,
            law.in_mid,
            law.scale,
            law.out_mid,
            *self._jac,
            self._full_m,
            s.ref_pos,
            s.ref_ori,
            s.ref_vel_p,
            s.ref_vel_r,
            s.j_pos,
            s.j_ori,
            s.j_full,
            s.joint_pos,
            s.joint_vel,
            s.mass,
            s.origin_pos,
            s.origin_ori,
            s.goal_pos,
            s.goal_ori,
            s.torques,
        )

    def substeps(
        self,
        law: _Law,
        count: int,
        policy_step: bool,
        cached_state: bool,
        command: np.ndarray,
        gripper_ctrl: np.ndarray,
    ) -> None:
        """``count`` compiled substeps (``mj_step1``, law, ``mj_step2``); with ``count = 0`` nothing happens."""
        s = self._state
        self._substeps(
            self._c.mj_step1,
            self._c.mj_step2,
            count,
            self._sensordata,
            s.first_pose,
            s.first_velocity,
            self._first_sensordata,
            *self._control_args(law, policy_step, cached_state, command, gripper_ctrl),
        )

    def control(self, action: Any, policy_step: bool = True) -> np.ndarray:
        """The arm torques (before the actuator clip) the law computes from the MuJoCo data as they stand (after
        ``mj_step1``), written into ``ctrl`` as one substep of :meth:`step` would; a ``policy_step`` first sets the
        goal and the gripper command from the robot ``action``. Robot and env bookkeeping are left alone: this
        is the law alone, to compare with robosuite's controllers."""
        law = self._current_law()
        robot_action = np.asarray(action, dtype=np.float64).reshape(-1)[: self.env.robots[0].action_dim]
        if policy_step:
            self._gripper_ctrl = self.gripper_ctrl(law, robot_action[law.gripper_slice])
        elif self._gripper_ctrl.shape != law.gripper_actuators.shape:
            raise ValueError(
                "FastStep.control(policy_step=False) before a policy step: expected a first call with "
                "policy_step=True (it sets the goal and the gripper command)"
            )
        cached_state = not law.arm.new_update  # as in step: a controller that has not run yet uses its cache
        if cached_state:
            self._state.load(law.arm)
        self._control(
            *self._control_args(
                law, policy_step, cached_state, np.ascontiguousarray(robot_action[law.arm_slice]), self._gripper_ctrl
            )
        )
        law.arm.new_update = True
        return self._state.torques.copy()

    def run_substeps(self, action: Any, count: int) -> None:
        """``count`` compiled substeps with the goal and gripper command set from the robot ``action`` at the first:
        the control and physics of :meth:`step` alone (no observables, records or env bookkeeping); the
        controllers are left as after such a step. For measuring the loop against other ways of running it."""
        law = self._current_law()
        robot_action = np.asarray(action, dtype=np.float64).reshape(-1)[: self.env.robots[0].action_dim]
        gripper_ctrl = self.gripper_ctrl(law, robot_action[law.gripper_slice])
        cached_state = not law.arm.new_update
        if cached_state:
            self._state.load(law.arm)
        self.substeps(law, count, True, cached_state, np.ascontiguousarray(robot_action[law.arm_slice]), gripper_ctrl)
        self._state.store(law.arm)

    def step(self, action: Any) -> tuple[dict[str, Any], float, bool, dict[str, Any]]:
        """One control step with the env-level ``action``: robosuite's ``MujocoEnv.step``."""
        reward, done, info = self.advance(action)
        env = self.env
        observations = env.viewer._get_observations() if env.viewer_get_obs else env._get_observations()
        return observations, reward, done, info

    def advance(self, action: Any) -> tuple[float, bool, dict[str, Any]]:
        """:meth:`step` without assembling the observation dict (``(reward, done, info)``): the observables hold
        the new values (``env._observables[key].obs``, what ``_get_observations`` would return)."""
        env = self.env
        if env.done:
            raise ValueError("executing action in terminated episode")
        action = np.asarray(action, dtype=np.float64).reshape(-1)
        if action.shape[0] != env.action_dim:
            raise ValueError(f"action has {action.shape[0]} values: expected the env's action_dim = {env.action_dim}")
        env.timestep += 1
        law = self._current_law()
        robot = env.robots[0]
        robot_action = action[: robot.action_dim]
        command = np.ascontiguousarray(robot_action[law.arm_slice])
        gripper_ctrl = self.gripper_ctrl(law, robot_action[law.gripper_slice])
        cached_state = not law.arm.new_update  # substep 0 reuses the controller's cached state (see osc_law)
        if cached_state:
            self._state.load(law.arm)
        joint_positions = np.array(
            env.sim.data.qpos[robot._ref_joint_pos_indexes]
        )  # robot._joint_positions at substep 0
        count = int(env.control_timestep / env.model_timestep)
        plan = sampling_plan(env._observables, env.model_timestep, count)
        start = 0
        for substep in plan.substeps:
            self.substeps(law, substep + 1 - start, start == 0, cached_state and start == 0, command, gripper_ctrl)
            start = substep + 1
            sample(plan, substep, env._obs_cache)
        self.substeps(law, count - start, start == 0, cached_state and start == 0, command, gripper_ctrl)
        finish(plan)
        self._record(law, robot, robot_action, joint_positions)
        env.cur_time += env.control_timestep
        reward, done, info = env._post_action(action)
        if env.viewer is not None and env.renderer != "mujoco":
            env.viewer.update()
        elif env.has_renderer and env.renderer == "mjviewer" and env.viewer is None:
            env.initialize_renderer()
            env.viewer.update()  # pyright: ignore[reportAttributeAccessIssue]  (initialize_renderer set the viewer)
        return reward, done, info

    def _record(self, law: _Law, robot: Any, robot_action: np.ndarray, joint_positions: np.ndarray) -> None:
        """The controllers' state after the step and ``FixedBaseRobot.control``'s policy-step records."""
        import robosuite.utils.transform_utils as T  # noqa: PLC0415

        s, arm = self._state, law.arm
        s.store(arm)
        arm_name = robot.arms[0]
        pose, velocity, sensordata = s.first_pose, s.first_velocity, self._first_sensordata
        robot.recent_qpos.push(joint_positions)
        robot.recent_actions.push(robot_action)
        robot.recent_torques.push(robot.torques)
        robot.recent_ee_forcetorques[arm_name].push(
            np.concatenate((sensordata[law.force_sensor], sensordata[law.torque_sensor]))
        )
        robot.recent_ee_pose[arm_name].push(np.concatenate((pose[0:3], T.mat2quat(pose[3:12].reshape(3, 3)))))
        robot.recent_ee_vel[arm_name].push(np.array(velocity))
        buffer = robot.recent_ee_vel_buffer[arm_name]
        buffer.push(velocity)
        diffs = np.vstack([robot.recent_ee_acc[arm_name].current, robot.control_freq * np.diff(buffer.buf, axis=0)])
        # robosuite: per column, np.convolve(column, np.ones(10) / 10.0, mode="valid")[0]; the diffs have the
        # buffer's 10 rows, so that is the mean of every column
        window = np.ones(diffs.shape[0]) / float(diffs.shape[0])
        robot.recent_ee_acc[arm_name].push(window @ diffs)


class _ArmState:
    """The compiled law's state buffers: what ``Controller.update`` caches, the goal, the torques."""

    def __init__(self, dof: int) -> None:
        self.ref_pos, self.ref_ori = np.zeros(3), np.zeros((3, 3))
        self.ref_vel_p, self.ref_vel_r = np.zeros(3), np.zeros(3)
        self.j_pos, self.j_ori, self.j_full = np.zeros((3, dof)), np.zeros((3, dof)), np.zeros((6, dof))
        self.joint_pos, self.joint_vel, self.mass = np.zeros(dof), np.zeros(dof), np.zeros((dof, dof))
        self.origin_pos, self.origin_ori = np.zeros(3), np.zeros((3, 3))
        self.goal_pos, self.goal_ori = np.zeros(3), np.zeros((3, 3))
        self.torques = np.zeros(dof)
        self.first_pose, self.first_velocity = np.zeros(12), np.zeros(6)  # substep 0 of a policy step

    def load(self, arm: Any) -> None:
        """The state an OSC controller cached at its last ``update`` (used while ``new_update`` is False)."""
        self.ref_pos[:], self.ref_ori[:] = arm.ref_pos, arm.ref_ori_mat
        self.ref_vel_p[:], self.ref_vel_r[:] = arm.ref_pos_vel, arm.ref_ori_vel
        self.j_pos[:], self.j_ori[:], self.j_full[:] = arm.J_pos, arm.J_ori, arm.J_full
        self.joint_pos[:], self.joint_vel[:], self.mass[:] = arm.joint_pos, arm.joint_vel, arm.mass_matrix

    def store(self, arm: Any) -> None:
        """Leave the OSC controller as its own last substep would: state, origin, goal, torques, refresh flag."""
        arm.ref_pos[:], arm.ref_ori_mat[:] = self.ref_pos, self.ref_ori
        arm.ref_pos_vel[:], arm.ref_ori_vel[:] = self.ref_vel_p, self.ref_vel_r
        arm.J_pos[:], arm.J_ori[:], arm.J_full[:] = self.j_pos, self.j_ori, self.j_full
        arm.joint_pos, arm.joint_vel, arm.mass_matrix = self.joint_pos.copy(), self.joint_vel.copy(), self.mass.copy()
        arm.origin_pos, arm.origin_ori = self.origin_pos.copy(), self.origin_ori.copy()
        arm.goal_pos, arm.goal_ori = self.goal_pos.copy(), self.goal_ori.copy()
        arm.torques = self.torques.copy()
        arm.new_update = True
