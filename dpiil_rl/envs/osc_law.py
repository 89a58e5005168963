"""robosuite's OSC_POSE law for one arm, compiled with numba, and the MuJoCo substep loop that applies it.

The law is that of robosuite 1.5.2 (``robosuite.controllers.parts.arm.osc.OperationalSpaceController`` with
``input_type="delta"``, ``input_ref_frame="base"``, fixed impedance, no interpolators, goals updated from the
achieved pose), and the substep is that of ``robosuite.environments.base.MujocoEnv.step`` with
``lite_physics``: ``mj_step1``, the controllers, ``mj_step2``. ``orientation_error`` and ``quat2mat`` are
robosuite's own compiled functions (``robosuite.utils.control_utils``, ``robosuite.utils.transform_utils``,
numba dispatchers while ``robosuite.macros.ENABLE_NUMBA``; ``quat2mat`` rounds through float32, and so does the
goal here); ``opspace_matrices`` and ``nullspace_torques`` are robosuite's formulas written out with small
loops instead of BLAS / LAPACK calls, whose overhead dominates at 6 x 6 (:func:`psd_pseudo_inverse`).

Goal, once per control step from the 6-D arm command ``a`` and the state after ``mj_step1``
(``OperationalSpaceController.set_goal`` / ``compute_goal_pos`` / ``compute_goal_ori``)::

    s   = (clip(a, in_min, in_max) - in_mid) * scale + out_mid          (Controller.scale_action)
    g_p = R_o^T x - R_o^T p_o + s[0:3]                                 (goal position, base frame)
    G_R = quat2mat(axisangle2quat(s[3:6])) R_o^T R                      (goal orientation, base frame)

with ``p_o, R_o`` the pose of the arm's base site (``robot0_right_center``) and ``x, R`` of the grip site.
Torques, every substep from the updated state (``OperationalSpaceController.run_controller``)::

    e_p = p_o + R_o g_p - x,   e_R = orientation_error(R_o G_R, R)
    F   = kp[0:3] e_p + kd[0:3] (v_o - v),   T = kp[3:6] e_R + kd[3:6] (w_o - w)
    M^-1, Lambda = (J M^-1 J^T)^+, Lambda_p, Lambda_R (the same of J_p, J_R), N = I - M^-1 J^T Lambda J
    tau = J^T [Lambda_p F; Lambda_R T] + qfrc_bias + N^T M (k_n (q_0 - q) - 2 sqrt(k_n) qdot)

(``J^T Lambda [F; T]`` when pos / ori are not uncoupled), where ``v, w`` / ``v_o, w_o`` are the site
velocities ``jac @ qvel`` of the grip / base site, ``M`` the arm block of the dense inertia (``mj_fullM``),
``q_0`` the controller's initial joints and ``k_n`` ``nullspace_torques``' default gain.
``FixedBaseRobot.control`` writes ``clip(tau, ctrlrange)`` into ``ctrl`` and the gripper's (constant over
the step) command next to it.

robosuite skips a controller's state refresh until it has run once (``Controller.new_update``): on the first
control step after a reset, substep 0 uses the state the controller cached when it was built. The caller
then fills the state buffers from that cache and sets ``cached_state``.

The first use compiles these functions (≈ 20 s on two busy cores) into ``__pycache__``; later processes
load them in well under a second. numba checks only this file for changes: after editing
:mod:`dpiil_rl.envs.mujoco_c` (whose intrinsics are compiled in here), touch this file.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from robosuite.utils.control_utils import orientation_error
from robosuite.utils.transform_utils import quat2mat

from dpiil_rl.envs.mujoco_c import call_full_m, call_jac_site, call_model_data


@njit(cache=True)
def axis_angle_to_quat(vec: np.ndarray) -> np.ndarray:
    """``robosuite.utils.transform_utils.axisangle2quat``: (x, y, z, w) of the rotation ``vec`` (axis * angle)."""
    angle = math.sqrt(vec[0] * vec[0] + vec[1] * vec[1] + vec[2] * vec[2])  # np.linalg.norm(vec)
    q = np.zeros(4)
    if angle == 0.0:  # math.isclose(angle, 0.0) with its default tolerances: only zero itself
        q[3] = 1.0
        return q
    axis = vec / angle
    q[3] = np.cos(angle / 2.0)
    q[:3] = axis * np.sin(angle / 2.0)
    return q


#: numba's ``np.linalg.pinv`` (which robosuite's compiled ``opspace_matrices`` calls) drops singular values at or
#: below ``PINV_RCOND`` times the largest; a matrix whose condition number is provably below this bound keeps
#: them all, and its pseudo-inverse is its inverse
PINV_RCOND = 1e-15
INVERSE_CONDITION_BOUND = 1e12
Array = np.ndarray  # float64 (indices: int64) arrays, C-contiguous; MuJoCo data fields are views of mjData


@njit(cache=True)
def matmul(a: Array, b: Array) -> Array:
    """``a @ b`` for small matrices, without a BLAS call (whose overhead exceeds the arithmetic here)."""
    n, k = a.shape
    m = b.shape[1]
    out = np.zeros((n, m))
    for i in range(n):
        for p in range(k):
            a_ip = a[i, p]
            for j in range(m):
                out[i, j] += a_ip * b[p, j]
    return out


@njit(cache=True)
def matvec(a: Array, x: Array) -> Array:
    """``a @ x`` for a small matrix and vector."""
    n, k = a.shape
    out = np.zeros(n)
    for i in range(n):
        acc = 0.0
        for p in range(k):
            acc += a[i, p] * x[p]
        out[i] = acc
    return out


@njit(cache=True)
def gauss_jordan(a: Array) -> tuple[Array, bool]:
    """``(a^-1, True)`` of a small matrix by Gauss-Jordan elimination with partial pivoting, ``(_, False)`` at a
    zero pivot (singular)."""
    n = a.shape[0]
    work = a.copy()
    out = np.eye(n)
    for col in range(n):
        pivot = col
        best = abs(work[col, col])
        for row in range(col + 1, n):
            if abs(work[row, col]) > best:
                pivot, best = row, abs(work[row, col])
        if best == 0.0:
            return out, False
        if pivot != col:
            for k in range(n):
                work[col, k], work[pivot, k] = work[pivot, k], work[col, k]
                out[col, k], out[pivot, k] = out[pivot, k], out[col, k]
        scale = 1.0 / work[col, col]
        for k in range(n):
            work[col, k] *= scale
            out[col, k] *= scale
        for row in range(n):
            if row != col:
                factor = work[row, col]
                if factor != 0.0:
                    for k in range(n):
                        work[row, k] -= factor * work[col, k]
                        out[row, k] -= factor * out[col, k]
    return out, True


@njit(cache=True)
def inverse(a: Array) -> Array:
    """``np.linalg.inv(a)`` of a small matrix (:func:`gauss_jordan`: LAPACK's LU with its call overhead takes
    several times longer at 6 x 6); a singular ``a`` goes to ``np.linalg.inv``, which raises as robosuite's would."""
    result, regular = gauss_jordan(a)
    if not regular:
        return np.linalg.inv(a)
    return result


@njit(cache=True)
def psd_pseudo_inverse(a: Array) -> Array:
    """``np.linalg.pinv(a)`` of a symmetric positive semi-definite ``a`` (the operational-space inertias).

    For such a matrix the largest singular value is at most ``trace(a)`` and the smallest at least
    ``1 / trace(a^-1)``; when their ratio bound is below :data:`INVERSE_CONDITION_BOUND` (far below
    ``1 / PINV_RCOND``) pinv keeps every singular value and equals the inverse, computed by :func:`inverse`
    (well under a microsecond where numba's SVD-based pinv takes 2-5 us). Otherwise it is pinv itself."""
    n = a.shape[0]
    trace = 0.0
    for i in range(n):
        trace += a[i, i]
    if trace > 0.0 and np.isfinite(trace):
        result, regular = gauss_jordan(a)
        trace_inverse = 0.0
        for i in range(n):
            trace_inverse += result[i, i]
        if regular and trace_inverse > 0.0 and trace * trace_inverse < INVERSE_CONDITION_BOUND:
            return result
    return np.linalg.pinv(a, PINV_RCOND)


@njit(cache=True)
def opspace_matrices(mass: Array, j_full: Array, j_pos: Array, j_ori: Array) -> tuple[Array, Array, Array, Array]:
    """``robosuite.utils.control_utils.opspace_matrices``: Lambda = (J M^-1 J^T)^+, the same for the position and
    orientation rows, and the nullspace projector N = I - M^-1 J^T Lambda J."""
    mass_inv = inverse(mass)
    lambda_full_inv = matmul(matmul(j_full, mass_inv), j_full.T)
    # J_p M^-1 J_p^T and J_R M^-1 J_R^T are the diagonal blocks of J M^-1 J^T (J = [J_p; J_R]), term for term
    lambda_full = psd_pseudo_inverse(lambda_full_inv)
    lambda_pos = psd_pseudo_inverse(np.ascontiguousarray(lambda_full_inv[:3, :3]))
    lambda_ori = psd_pseudo_inverse(np.ascontiguousarray(lambda_full_inv[3:, 3:]))
    j_bar = matmul(matmul(mass_inv, j_full.T), lambda_full)
    nullspace = np.eye(j_full.shape[1]) - matmul(j_bar, j_full)
    return lambda_full, lambda_pos, lambda_ori, nullspace


@njit(cache=True)
def nullspace_torques(
    mass: Array, nullspace: Array, initial_joint: Array, joint_pos: Array, joint_vel: Array, joint_kp: float
) -> Array:
    """``robosuite.utils.control_utils.nullspace_torques``: N^T M (kp (q_0 - q) - 2 sqrt(kp) qdot)."""
    joint_kv = np.sqrt(joint_kp) * 2
    pose_torques = matvec(mass, joint_kp * (initial_joint - joint_pos) - joint_kv * joint_vel)
    return matvec(nullspace.T, pose_torques)


@njit(cache=True)
def read_arm_state(
    jac_site: int,
    m_addr: int,
    d_addr: int,
    site: int,
    qpos: Array,
    qvel: Array,
    qm: Array,
    qpos_index: Array,
    qvel_index: Array,
    jacp: Array,
    jacr: Array,
    full_m: Array,
    ref_pos: Array,
    ref_ori: Array,
    ref_vel_p: Array,
    ref_vel_r: Array,
    j_pos: Array,
    j_ori: Array,
    j_full: Array,
    joint_pos: Array,
    joint_vel: Array,
    mass: Array,
    site_xpos: Array,
    site_xmat: Array,
    full_m_fn: int,
) -> None:
    """``Controller.update``: grip-site pose, velocity and Jacobians, arm joints and the arm's inertia block."""
    ref_pos[:] = site_xpos[site]
    ref_ori[:, :] = site_xmat[site].reshape(3, 3)
    call_jac_site(jac_site, m_addr, d_addr, jacp.ctypes.data, jacr.ctypes.data, site)
    ref_vel_p[:] = matvec(jacp, qvel)
    ref_vel_r[:] = matvec(jacr, qvel)
    n = qvel_index.shape[0]
    for k in range(n):
        j_pos[:, k] = jacp[:, qvel_index[k]]
        j_ori[:, k] = jacr[:, qvel_index[k]]
        joint_pos[k] = qpos[qpos_index[k]]
        joint_vel[k] = qvel[qvel_index[k]]
    j_full[:3] = j_pos
    j_full[3:] = j_ori
    call_full_m(full_m_fn, m_addr, full_m.ctypes.data, qm.ctypes.data)
    for a in range(n):
        for b in range(n):
            mass[a, b] = full_m[qvel_index[a], qvel_index[b]]


@njit(cache=True)
def set_goal(
    command: Array,
    in_min: Array,
    in_max: Array,
    in_mid: Array,
    scale: Array,
    out_mid: Array,
    origin_pos: Array,
    origin_ori: Array,
    ref_pos: Array,
    ref_ori: Array,
    goal_pos: Array,
    goal_ori: Array,
) -> None:
    """``OperationalSpaceController.set_goal`` (delta input, base frame, achieved mode) into ``goal_pos / goal_ori``."""
    scaled = (np.minimum(np.maximum(command, in_min), in_max) - in_mid) * scale + out_mid
    base_t = origin_ori.T
    goal_pos[:] = matvec(base_t, ref_pos) + (-matvec(base_t, origin_pos)) + scaled[0:3]
    rotation = quat2mat(axis_angle_to_quat(np.ascontiguousarray(scaled[3:6])))
    goal_ori[:, :] = matmul(rotation, matmul(base_t, ref_ori))


@njit(cache=True)
def osc_torques(
    origin_pos: Array,
    origin_ori: Array,
    goal_pos: Array,
    goal_ori: Array,
    ref_pos: Array,
    ref_ori: Array,
    ref_vel_p: Array,
    ref_vel_r: Array,
    base_vel_p: Array,
    base_vel_r: Array,
    kp: Array,
    kd: Array,
    mass: Array,
    j_full: Array,
    j_pos: Array,
    j_ori: Array,
    bias: Array,
    initial_joint: Array,
    joint_pos: Array,
    joint_vel: Array,
    null_kp: float,
    uncoupled: bool,
    torques: Array,
) -> None:
    """``OperationalSpaceController.run_controller``: the arm torques (before the actuator clip) into ``torques``."""
    desired_pos = origin_pos + matvec(origin_ori, goal_pos)
    desired_ori = matmul(origin_ori, goal_ori)
    ori_error = orientation_error(desired_ori, ref_ori)
    force = (desired_pos - ref_pos) * kp[0:3] + (-(ref_vel_p - base_vel_p)) * kd[0:3]
    moment = ori_error * kp[3:6] + (-(ref_vel_r - base_vel_r)) * kd[3:6]
    lambda_full, lambda_pos, lambda_ori, nullspace = opspace_matrices(mass, j_full, j_pos, j_ori)
    wrench = np.empty(6)
    if uncoupled:
        wrench[0:3] = matvec(lambda_pos, force)
        wrench[3:6] = matvec(lambda_ori, moment)
    else:
        wrench[0:3] = force
        wrench[3:6] = moment
        wrench = matvec(lambda_full, wrench)
    torques[:] = matvec(j_full.T, wrench) + bias
    torques += nullspace_torques(mass, nullspace, initial_joint, joint_pos, joint_vel, null_kp)


@njit(cache=True)
def control(
    jac_site: int,
    full_m_fn: int,
    m_addr: int,
    d_addr: int,
    qpos: Array,
    qvel: Array,
    qm: Array,
    qfrc_bias: Array,
    site_xpos: Array,
    site_xmat: Array,
    ctrl: Array,
    policy_step: bool,
    cached_state: bool,
    command: Array,
    grip_site: int,
    base_site: int,
    qpos_index: Array,
    qvel_index: Array,
    arm_actuators: Array,
    gripper_actuators: Array,
    gripper_ctrl: Array,
    ctrl_min: Array,
    ctrl_max: Array,
    kp: Array,
    kd: Array,
    null_kp: float,
    uncoupled: bool,
    initial_joint: Array,
    in_min: Array,
    in_max: Array,
    in_mid: Array,
    scale: Array,
    out_mid: Array,
    jacp: Array,
    jacr: Array,
    base_jacp: Array,
    base_jacr: Array,
    full_m: Array,
    ref_pos: Array,
    ref_ori: Array,
    ref_vel_p: Array,
    ref_vel_r: Array,
    j_pos: Array,
    j_ori: Array,
    j_full: Array,
    joint_pos: Array,
    joint_vel: Array,
    mass: Array,
    origin_pos: Array,
    origin_ori: Array,
    goal_pos: Array,
    goal_ori: Array,
    torques: Array,
) -> None:
    """What ``RobotEnv._pre_action`` does between ``mj_step1`` and ``mj_step2``: refresh the state (unless
    ``cached_state``), set the goal on a ``policy_step``, compute the torques, write ``ctrl``."""
    origin_pos[:] = site_xpos[base_site]  # CompositeController.update_state -> update_origin
    origin_ori[:, :] = site_xmat[base_site].reshape(3, 3)
    if not cached_state:
        read_arm_state(
            jac_site,
            m_addr,
            d_addr,
            grip_site,
            qpos,
            qvel,
            qm,
            qpos_index,
            qvel_index,
            jacp,
            jacr,
            full_m,
            ref_pos,
            ref_ori,
            ref_vel_p,
            ref_vel_r,
            j_pos,
            j_ori,
            j_full,
            joint_pos,
            joint_vel,
            mass,
            site_xpos,
            site_xmat,
            full_m_fn,
        )
    if policy_step:
        set_goal(
            command,
            in_min,
            in_max,
            in_mid,
            scale,
            out_mid,
            origin_pos,
            origin_ori,
            ref_pos,
            ref_ori,
            goal_pos,
            goal_ori,
        )
    call_jac_site(jac_site, m_addr, d_addr, base_jacp.ctypes.data, base_jacr.ctypes.data, base_site)
    base_vel_p = matvec(base_jacp, qvel)
    base_vel_r = matvec(base_jacr, qvel)
    n = qvel_index.shape[0]
    bias = np.empty(n)
    for k in range(n):
        bias[k] = qfrc_bias[qvel_index[k]]  # Controller.torque_compensation
    osc_torques(
        origin_pos,
        origin_ori,
        goal_pos,
        goal_ori,
        ref_pos,
        ref_ori,
        ref_vel_p,
        ref_vel_r,
        base_vel_p,
        base_vel_r,
        kp,
        kd,
        mass,
        j_full,
        j_pos,
        j_ori,
        bias,
        initial_joint,
        joint_pos,
        joint_vel,
        null_kp,
        uncoupled,
        torques,
    )
    for k in range(arm_actuators.shape[0]):
        ctrl[arm_actuators[k]] = np.minimum(np.maximum(torques[k], ctrl_min[k]), ctrl_max[k])  # np.clip (NaN stays)
    for k in range(gripper_actuators.shape[0]):
        ctrl[gripper_actuators[k]] = gripper_ctrl[k]


@njit(cache=True)
def run_substeps(
    step1: int,
    step2: int,
    count: int,
    sensordata: Array,
    first_pose: Array,
    first_velocity: Array,
    first_sensordata: Array,
    jac_site: int,
    full_m_fn: int,
    m_addr: int,
    d_addr: int,
    qpos: Array,
    qvel: Array,
    qm: Array,
    qfrc_bias: Array,
    site_xpos: Array,
    site_xmat: Array,
    ctrl: Array,
    policy_step: bool,
    cached_state: bool,
    command: Array,
    grip_site: int,
    base_site: int,
    qpos_index: Array,
    qvel_index: Array,
    arm_actuators: Array,
    gripper_actuators: Array,
    gripper_ctrl: Array,
    ctrl_min: Array,
    ctrl_max: Array,
    kp: Array,
    kd: Array,
    null_kp: float,
    uncoupled: bool,
    initial_joint: Array,
    in_min: Array,
    in_max: Array,
    in_mid: Array,
    scale: Array,
    out_mid: Array,
    jacp: Array,
    jacr: Array,
    base_jacp: Array,
    base_jacr: Array,
    full_m: Array,
    ref_pos: Array,
    ref_ori: Array,
    ref_vel_p: Array,
    ref_vel_r: Array,
    j_pos: Array,
    j_ori: Array,
    j_full: Array,
    joint_pos: Array,
    joint_vel: Array,
    mass: Array,
    origin_pos: Array,
    origin_ori: Array,
    goal_pos: Array,
    goal_ori: Array,
    torques: Array,
) -> None:
    """``count`` substeps of ``mj_step1`` -> :func:`control` -> ``mj_step2`` (the arguments from ``jac_site`` on are
    :func:`control`'s). On a ``policy_step`` the first one sets the goal and records what
    ``FixedBaseRobot.control`` logs on a policy step: the grip-site pose (``first_pose``: position, rotation
    rows), its velocity (``first_velocity``) and ``sensordata`` (``first_sensordata``)."""
    for i in range(count):
        call_model_data(step1, m_addr, d_addr)
        first = policy_step and i == 0
        cached = cached_state and i == 0
        control(
            jac_site,
            full_m_fn,
            m_addr,
            d_addr,
            qpos,
            qvel,
            qm,
            qfrc_bias,
            site_xpos,
            site_xmat,
            ctrl,
            first,
            cached,
            command,
            grip_site,
            base_site,
            qpos_index,
            qvel_index,
            arm_actuators,
            gripper_actuators,
            gripper_ctrl,
            ctrl_min,
            ctrl_max,
            kp,
            kd,
            null_kp,
            uncoupled,
            initial_joint,
            in_min,
            in_max,
            in_mid,
            scale,
            out_mid,
            jacp,
            jacr,
            base_jacp,
            base_jacr,
            full_m,
            ref_pos,
            ref_ori,
            ref_vel_p,
            ref_vel_r,
            j_pos,
            j_ori,
            j_full,
            joint_pos,
            joint_vel,
            mass,
            origin_pos,
            origin_ori,
            goal_pos,
            goal_ori,
            torques,
        )
        if first:
            first_pose[0:3] = ref_pos
            first_pose[3:12] = ref_ori.ravel()
            first_velocity[0:3] = ref_vel_p
            first_velocity[3:6] = ref_vel_r
            first_sensordata[:] = sensordata
        call_model_data(step2, m_addr, d_addr)
