"""A simulated UR5e behind the :class:`~dpiil_rl.robots.interface.RobotBackend` interface (MuJoCo).

The arm is robosuite's UR5e model with a rigid gripper (:func:`~dpiil_rl.robots.sim_scene.build_mjcf`) on a
table with the task's scene. It is commanded like a real UR's ``speedL``: a TCP velocity per control
period, orientation held. Each period the velocity (ramped from the previous one within the
acceleration bound, plus a small correction toward the integrated command so the TCP does not drift)
and an orientation-hold rate are mapped to joint velocities by damped least squares on the TCP site's
Jacobian (``mj_jacSite``); a computed-torque joint servo (mass matrix of the period, gravity and
Coriolis from ``qfrc_bias``) tracks the integrated joint reference over the MuJoCo substeps. Every
substep's contacts are checked: :attr:`RobotState.collision` is True if the arm, the gripper or what it
holds touched the table, the floor or a scene object during the last period.

robosuite and MuJoCo are imported in :meth:`SimUR5eBackend.connect`, never when this module is imported.
Compiled models are cached per process and shared by backends with the same scene (each has its own data).
"""

from __future__ import annotations

import json
import math
from typing import Any, Mapping, Sequence

import numpy as np

from dpiil_rl.robots.interface import RobotBackend, RobotState, RobotUnavailable
from dpiil_rl.robots.sim_scene import (
    ENV_CONTYPE,
    HELD_PREFIX,
    ROBOT_CONTYPE,
    ROBOT_PREFIXES,
    Scene,
    build_mjcf,
    matrix_to_quat,
    quat_to_matrix,
    rotation_error,
)

ARM_JOINTS = tuple(
    f"robot0_{j}_joint" for j in ("shoulder_pan", "shoulder_lift", "elbow", "wrist_1", "wrist_2", "wrist_3")
)
TCP_SITE = "gripper0_grip_site"
BASE_BODY = "robot0_base"
#: robosuite's UR5e start pose: gripper pointing down, fingers opening along the base y axis
ROBOSUITE_HOME = (-0.47, -1.735, 2.48, -2.275, -1.59, -1.991)
#: TCP z axis straight down, fingers (TCP x axis) along base y: (w, x, y, z)
TOOL_DOWN = (0.0, 0.70710678, 0.70710678, 0.0)

_MODELS: dict[str, Any] = {}  # cache key (JSON of the build settings) -> compiled MjModel


class SimUR5eBackend(RobotBackend):
    """A UR5e in MuJoCo, TCP-velocity controlled like ``speedL`` (see the module docstring)."""

    _mj: Any  # the mujoco module, bound at connect (compiled bindings without type information)

    def __init__(
        self,
        scene: Mapping[str, Any] | Scene,
        control_period: float = 0.05,
        timestep: float = 0.005,
        gripper: str = "Robotiq85Gripper",
        home_joints: Sequence[float] = ROBOSUITE_HOME,
        tcp_orientation: Sequence[float] = TOOL_DOWN,
        base_height: float = 0.8,
        servo_bandwidth: float = 50.0,
        drift_gain: float = 5.0,
        orientation_gain: float = 5.0,
        damping: float = 0.01,
        max_joint_speed: float = math.pi,
        max_tracking_error: float = 0.05,
        max_drift: float = 0.01,
        settle_time: float = 0.1,
        ik_tolerance: float = 1e-5,
        ik_iterations: int = 200,
    ) -> None:
        super().__init__()
        self.scene = Scene.from_mapping(scene, "robot.scene")
        for name, value in {
            "control_period": control_period,
            "timestep": timestep,
            "servo_bandwidth": servo_bandwidth,
            "damping": damping,
            "max_joint_speed": max_joint_speed,
            "max_tracking_error": max_tracking_error,
            "max_drift": max_drift,
            "ik_tolerance": ik_tolerance,
        }.items():
            if not float(value) > 0:
                raise ValueError(f"robot.{name} = {value}: expected a positive number")
        for name, value in {
            "drift_gain": drift_gain,
            "orientation_gain": orientation_gain,
            "settle_time": settle_time,
            "base_height": base_height,
        }.items():
            if not float(value) >= 0:
                raise ValueError(f"robot.{name} = {value}: expected a number >= 0")
        substeps = float(control_period) / float(timestep)
        if abs(substeps - round(substeps)) > 1e-6 or round(substeps) < 1:
            raise ValueError(
                f"robot.timestep = {timestep}: "
                f"expected control_period = {control_period} to be a whole number of timesteps"
            )
        if len(home_joints) != 6:
            raise ValueError(f"robot.home_joints = {list(home_joints)}: expected 6 joint angles (rad)")
        quat = np.asarray(tcp_orientation, dtype=np.float64)
        if quat.shape != (4,) or not np.linalg.norm(quat) > 0:
            raise ValueError(f"robot.tcp_orientation = {list(tcp_orientation)}: expected a quaternion (w, x, y, z)")
        if int(ik_iterations) < 1:
            raise ValueError(f"robot.ik_iterations = {ik_iterations}: expected at least one iteration")
        self.control_period = float(control_period)
        self.timestep = float(timestep)
        self.substeps = int(round(substeps))
        self.gripper = str(gripper)
        self.home_joints = np.asarray(home_joints, dtype=np.float64)
        self.tool_rotation = quat_to_matrix(quat)  # held TCP orientation in the base frame
        self.base_height = float(base_height)
        self.kp = float(servo_bandwidth) ** 2  # computed torque: critically damped unit-mass error dynamics
        self.kd = 2.0 * float(servo_bandwidth)
        self.drift_gain = float(drift_gain)
        self.orientation_gain = float(orientation_gain)
        self.damping = float(damping)
        self.max_joint_speed = float(max_joint_speed)
        self.max_tracking_error = float(max_tracking_error)
        self.max_drift = float(max_drift)
        self.settle_time = float(settle_time)
        self.ik_tolerance = float(ik_tolerance)
        self.ik_iterations = int(ik_iterations)

    # ---------------------------------------------------------------------------- lifecycle
    def connect(self) -> None:
        """Build (or take from the process cache) the model and put the arm at its home pose, orientation held."""
        if self._connected:
            return
        try:
            import mujoco  # noqa: PLC0415  (lazy: only simulated robots load MuJoCo)

            self._mj = mujoco
            model = self._model()
        except ImportError as err:  # pragma: no cover - the pinned environment has both
            raise RobotUnavailable(
                f"simulated UR5e: {err}; install the pinned simulators: pip install mujoco==3.3.7 robosuite==1.5.2"
            ) from err
        mj = self._mj
        self._m = model
        self._d = mj.MjData(model)
        self._ik_data = mj.MjData(model)
        self._site = mj.mj_name2id(model, mj.mjtObj.mjOBJ_SITE, TCP_SITE)
        joints = [mj.mj_name2id(model, mj.mjtObj.mjOBJ_JOINT, j) for j in ARM_JOINTS]
        qadr = [int(model.jnt_qposadr[j]) for j in joints]
        dadr = [int(model.jnt_dofadr[j]) for j in joints]
        if qadr != list(range(qadr[0], qadr[0] + 6)) or dadr != list(range(dadr[0], dadr[0] + 6)):
            raise RuntimeError(f"simulated UR5e: arm joints are not contiguous in the model (qpos {qadr}, dofs {dadr})")
        self._q = slice(qadr[0], qadr[0] + 6)
        self._v = slice(dadr[0], dadr[0] + 6)
        actuators = [
            int(np.flatnonzero((model.actuator_trntype == 0) & (model.actuator_trnid[:, 0] == j))[0]) for j in joints
        ]
        self._act = np.array(actuators)
        self._torque_limit = np.abs(model.actuator_ctrlrange[self._act, 1])
        body_names = [model.body(i).name for i in range(model.nbody)]
        geom_body = np.asarray(model.geom_bodyid)
        moving = np.asarray(model.body_weldid) != 0  # the robot base is welded to the world and sits on the table
        robot_body = np.array([n.startswith(ROBOT_PREFIXES + (HELD_PREFIX,)) for n in body_names]) & moving
        self._robot_geom = robot_body[geom_body] & (np.asarray(model.geom_contype) == ROBOT_CONTYPE)
        self._env_geom = np.asarray(model.geom_contype) == ENV_CONTYPE
        self._body_names = body_names
        self._jacp = np.zeros((3, model.nv))
        self._jacr = np.zeros((3, model.nv))
        self._mass = np.zeros((model.nv, model.nv))
        self._vel6 = np.zeros(6)
        self._damping_eye = self.damping**2 * np.eye(6)
        mj.mj_forward(model, self._d)
        base = mj.mj_name2id(model, mj.mjtObj.mjOBJ_BODY, BASE_BODY)
        self._base_pos = np.array(self._d.xpos[base])
        self._base_rot = np.array(self._d.xmat[base]).reshape(3, 3)
        self._tool_world = self._base_rot @ self.tool_rotation
        self._v_prev = np.zeros(3)
        self._x_ref = np.zeros(3)
        self._q_ref = self.home_joints.copy()
        self._contact = False
        super().connect()
        self._set_joints(self.home_joints)
        home = self._to_base(np.array(self._d.site_xpos[self._site]))
        self.move_to(home, speed=0.1)  # align the tool to the held orientation

    def disconnect(self) -> None:
        if self._connected:
            self._v_prev = np.zeros(3)
        super().disconnect()

    def _model(self) -> Any:
        key = json.dumps(
            {
                "scene": self.scene.to_mapping(),
                "gripper": self.gripper,
                "base_height": self.base_height,
                "tool": np.round(self.tool_rotation, 9).tolist(),
                "timestep": self.timestep,
            },
            sort_keys=True,
        )
        if key not in _MODELS:
            xml = build_mjcf(self.scene, self.gripper, self.base_height, self.tool_rotation, self.timestep)
            _MODELS[key] = self._mj.MjModel.from_xml_string(xml)
        return _MODELS[key]

    @property
    def model(self) -> Any:
        """The MuJoCo model (for rendering and inspection)."""
        self._require()
        return self._m

    @property
    def data(self) -> Any:
        """The MuJoCo data (for rendering and inspection)."""
        self._require()
        return self._d

    def _require(self) -> None:
        if not self._connected:
            raise RobotUnavailable(
                "simulated UR5e: not connected; call connect() (or use it as a context manager) first"
            )

    # ---------------------------------------------------------------------------- frames
    def _to_base(self, p_world: np.ndarray) -> np.ndarray:
        return self._base_rot.T @ (p_world - self._base_pos)

    def _to_world(self, p_base: np.ndarray) -> np.ndarray:
        return self._base_pos + self._base_rot @ p_base

    # ---------------------------------------------------------------------------- state and motion
    def read_state(self) -> RobotState:
        self._require()
        m, d, mj = self._m, self._d, self._mj
        rot = self._base_rot.T @ np.asarray(d.site_xmat[self._site]).reshape(3, 3)
        mj.mj_objectVelocity(m, d, mj.mjtObj.mjOBJ_SITE, self._site, self._vel6, 0)
        return RobotState(
            tcp_position=self._to_base(np.array(d.site_xpos[self._site])),
            tcp_quaternion=matrix_to_quat(rot),
            tcp_velocity=self._base_rot.T @ self._vel6[3:],
            joint_positions=np.array(d.qpos[self._q]),
            protective_stop=False,
            collision=bool(self._contact),
            time=float(d.time),
        )

    def command_tcp_velocity(self, velocity: np.ndarray, acceleration: float) -> None:
        self._require()
        v = np.asarray(velocity, dtype=np.float64).reshape(3)
        if not np.all(np.isfinite(v)):
            raise ValueError(f"velocity = {v.tolist()}: expected finite numbers (m/s)")
        if not float(acceleration) > 0:
            raise ValueError(f"acceleration = {acceleration}: expected a positive bound (m/s^2)")
        d = self._d
        target = self._base_rot @ v
        change = target - self._v_prev
        limit = float(acceleration) * self.control_period
        size = float(np.linalg.norm(change))
        v_end = self._v_prev + (change * (limit / size) if size > limit else change)
        tcp = np.array(d.site_xpos[self._site])
        drift = self._x_ref - tcp
        norm = float(np.linalg.norm(drift))
        if norm > self.max_drift:  # held back (contact, joint speed limit): do not wind up
            drift *= self.max_drift / norm
            self._x_ref = tcp + drift
        spin = self.orientation_gain * rotation_error(
            self._tool_world, np.asarray(d.site_xmat[self._site]).reshape(3, 3)
        )
        start, end = self._dls_solve(
            d,
            np.concatenate([self._v_prev + self.drift_gain * drift, spin]),
            np.concatenate([v_end + self.drift_gain * drift, spin]),
        )
        peak = max(float(np.abs(start).max()), float(np.abs(end).max()))
        if peak > self.max_joint_speed:
            start *= self.max_joint_speed / peak
            end *= self.max_joint_speed / peak
        self._contact = self._run(start, end)
        self._x_ref = self._x_ref + 0.5 * (self._v_prev + v_end) * self.control_period
        self._v_prev = v_end

    def stop(self, deceleration: float) -> None:
        self._require()
        if not float(deceleration) > 0:
            raise ValueError(f"deceleration = {deceleration}: expected a positive bound (m/s^2)")
        periods = int(math.ceil(float(np.linalg.norm(self._v_prev)) / (float(deceleration) * self.control_period))) + 1
        for _ in range(periods):
            self.command_tcp_velocity(np.zeros(3), deceleration)

    def move_to(self, tcp_position: np.ndarray, speed: float) -> None:
        """Put the TCP at ``tcp_position`` with the held orientation and let the arm settle.

        The simulation does not drive the straight line: it solves the joint angles by inverse kinematics
        (from :attr:`home_joints`, so a position always gives the same joints), places the arm there at
        rest and holds it for ``settle_time`` (``speed`` is not used). Raises ``ValueError`` if the
        position cannot be reached with the held orientation.
        """
        self._require()
        del speed
        target = np.asarray(tcp_position, dtype=np.float64).reshape(3)
        q = self._solve_ik(self._to_world(target))
        self._set_joints(q)
        steps = int(round(self.settle_time / self.timestep))
        zero = np.zeros(6)
        contact = False
        for _ in range(max(1, int(math.ceil(steps / self.substeps)))):
            contact |= self._run(zero, zero)
        self._contact = contact
        self._x_ref = np.array(self._d.site_xpos[self._site])
        self._v_prev = np.zeros(3)

    # ---------------------------------------------------------------------------- capabilities of the simulation
    def contact_pairs(self) -> list[tuple[str, str]]:
        """(robot-side body, environment body) of every current robot-environment contact."""
        self._require()
        d = self._d
        out = []
        for k in range(int(d.ncon)):
            g1, g2 = int(d.contact.geom1[k]), int(d.contact.geom2[k])
            if self._robot_geom[g2] and self._env_geom[g1]:
                g1, g2 = g2, g1
            if self._robot_geom[g1] and self._env_geom[g2]:
                b1, b2 = self._m.geom_bodyid[g1], self._m.geom_bodyid[g2]
                out.append((self._body_names[b1], self._body_names[b2]))
        return out

    # ---------------------------------------------------------------------------- internals
    def _set_joints(self, q: np.ndarray) -> None:
        d = self._d
        d.qpos[:] = 0.0
        d.qvel[:] = 0.0
        d.qacc_warmstart[:] = 0.0
        d.qpos[self._q] = q
        d.ctrl[:] = 0.0
        self._q_ref = np.array(q, dtype=np.float64)
        self._mj.mj_forward(self._m, d)

    def _dls_solve(self, d: Any, *twists: np.ndarray) -> list[np.ndarray]:
        """Joint velocities ``J^T (J J^T + λ² I)^-1 twist`` (damped least squares on the TCP site's Jacobian at
        ``d``) for each 6-D twist (linear, angular; world frame). MuJoCo's Cholesky: no LAPACK call per step."""
        mj = self._mj
        mj.mj_jacSite(self._m, d, self._jacp, self._jacr, self._site)
        jac = np.vstack([self._jacp[:, self._v], self._jacr[:, self._v]])
        gram = jac @ jac.T + self._damping_eye
        mj.mju_cholFactor(gram, 0.0)
        out = []
        for twist in twists:
            y = np.zeros(6)
            mj.mju_cholSolve(y, gram, np.ascontiguousarray(twist, dtype=np.float64))
            out.append(jac.T @ y)
        return out

    def _run(self, start: np.ndarray, end: np.ndarray) -> bool:
        """One control period: joint velocities ramp from ``start`` to ``end``; True on any robot-environment
        contact."""
        m, d, mj = self._m, self._d, self._mj
        mj.mj_fullM(m, self._mass, d.qM)
        mass = self._mass[self._v, self._v].copy()
        q_ref = self._q_ref
        dt, n = self.timestep, self.substeps
        limit, err_max, kp, kd = self._torque_limit, self.max_tracking_error, self.kp, self.kd
        qpos, qvel, bias, ctrl = d.qpos, d.qvel, d.qfrc_bias, d.ctrl
        qs, vs, act = self._q, self._v, self._act
        delta = end - start
        contact = False
        for k in range(1, n + 1):
            qd = start + (k / n) * delta
            q_ref += qd * dt
            q = qpos[qs]
            err = q_ref - q
            if np.abs(err).max() > err_max:  # blocked: the reference waits for the arm
                err = np.clip(err, -err_max, err_max)
                q_ref[:] = q + err
            tau = mass @ (kp * err + kd * (qd - qvel[vs])) + bias[vs]
            ctrl[act] = np.minimum(np.maximum(tau, -limit), limit)
            mj.mj_step(m, d)
            if d.ncon:
                contact |= self._touching()
        mj.mj_forward(m, d)
        if d.ncon:
            contact |= self._touching()
        return contact

    def _touching(self) -> bool:
        d = self._d
        n = int(d.ncon)
        g1 = d.contact.geom1[:n]
        g2 = d.contact.geom2[:n]
        hits = (self._robot_geom[g1] & self._env_geom[g2]) | (self._robot_geom[g2] & self._env_geom[g1])
        return bool(hits.any())

    def _solve_ik(self, target_world: np.ndarray) -> np.ndarray:
        m, d, mj = self._m, self._ik_data, self._mj
        q = self.home_joints.copy()
        for _ in range(self.ik_iterations):
            d.qpos[self._q] = q
            mj.mj_kinematics(m, d)
            mj.mj_comPos(m, d)
            pos_err = target_world - d.site_xpos[self._site]
            rot_err = rotation_error(self._tool_world, np.asarray(d.site_xmat[self._site]).reshape(3, 3))
            if np.linalg.norm(pos_err) < self.ik_tolerance and np.linalg.norm(rot_err) < 10 * self.ik_tolerance:
                return q
            (step,) = self._dls_solve(d, np.concatenate([pos_err, rot_err]))
            size = float(np.linalg.norm(step))
            q = q + (step * (0.2 / size) if size > 0.2 else step)
        raise ValueError(
            f"tcp_position = {np.round(self._to_base(target_world), 4).tolist()}: "
            "the simulated UR5e cannot reach it with the held tool orientation "
            f"(inverse kinematics left {np.linalg.norm(pos_err):.2e} m, {np.linalg.norm(rot_err):.2e} rad)"
        )
