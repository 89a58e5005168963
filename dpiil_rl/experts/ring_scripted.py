"""A scripted careful person for the ring-threading task (docs/design.md, "Tasks").

A closed-loop state machine per robot, driven by the 51-D state alone (so it can label any state a
learner reaches, and recovers when the ring slips):

``REACH`` above the handle, turning the gripper to the handle's yaw → ``DESCEND`` onto it →
``CLOSE`` the gripper and wait for it to close → ``LIFT`` the ring above the pegs → ``TRANSPORT`` it
over the round peg, turning the handle toward the robot (the peg is at the edge of the UR5e's
reach) → ``INSERT``: go down only while the ring's centre is within ``xy_tolerance`` of the peg's
axis, else correct sideways first → ``RELEASE``. Losing the ring anywhere sends it back to ``REACH``.

Speed is fast in the open and slow near the constraint of the phase (the handle while grasping, the
peg top while inserting), and Gaussian noise grows with the commanded speed (signal-dependent noise).
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

import torch

from dpiil_rl.envs.ring_task import (
    GRIPPER_CLOSED_QPOS,
    RingGeometry,
    RingState,
    handle_offsets,
    handle_position,
    heading,
    holds_handle,
    quat_to_matrix,
    tilt_correction,
    wrap_angle,
)


class Phase(enum.IntEnum):
    REACH = 0
    DESCEND = 1
    CLOSE = 2
    LIFT = 3
    TRANSPORT = 4
    INSERT = 5
    RELEASE = 6


@dataclass(frozen=True)
class RingTakeoverRule:
    """HG-DAgger on the ring: when this expert, supervising the robot, grabs control and hands it back."""

    max_gap: float = 0.35  # take over if the learner's translation differs from the expert's by this (action units)
    insert_height: float = 0.04  # ... or the ring's bottom is within this of the peg top while over the peg (m)
    release_gap: float = 0.15  # hand back only when the learner agrees within this, away from the peg


class RingScriptedPolicy:
    """Vectorised state-machine expert for :class:`~dpiil_rl.envs.ring.RingEnv` (6-D actions in [-1, 1])."""

    def __init__(
        self,
        geometry: RingGeometry,
        hover_height: float,
        grasp_height: float,
        transport_z: float,
        speed_max: float,
        speed_min: float,
        speed_distance: float,
        gain: float,
        yaw_gain: float,
        tilt_gain: float,
        xy_tolerance: float,
        yaw_tolerance: float,
        close_steps: int,
        noise_floor: float,
        noise_gain: float,
        takeover: dict | None = None,
    ) -> None:
        for name, value in (
            ("speed_max", speed_max),
            ("speed_distance", speed_distance),
            ("gain", gain),
            ("xy_tolerance", xy_tolerance),
            ("yaw_tolerance", yaw_tolerance),
        ):
            if not value > 0:
                raise ValueError(f"env.expert.{name} = {value}: expected a positive number")
        if not 0 <= speed_min <= speed_max <= 1:
            raise ValueError(
                f"env.expert speed_min = {speed_min}, speed_max = {speed_max}: expected 0 <= min <= max <= 1"
            )
        if transport_z - geometry.ring_half_height <= geometry.peg_top_z:
            raise ValueError(
                f"env.expert.transport_z = {transport_z}: "
                f"expected the ring to clear the peg tops at {geometry.peg_top_z} m"
            )
        if noise_floor < 0 or noise_gain < 0:
            raise ValueError(f"env.expert noise_floor = {noise_floor}, noise_gain = {noise_gain}: expected >= 0")
        self.g = geometry
        self.hover_height, self.grasp_height, self.transport_z = hover_height, grasp_height, transport_z
        self.speed_max, self.speed_min, self.speed_distance = speed_max, speed_min, speed_distance
        self.gain, self.yaw_gain, self.tilt_gain = gain, yaw_gain, tilt_gain
        self.xy_tolerance, self.yaw_tolerance = xy_tolerance, yaw_tolerance
        self.close_steps = int(close_steps)
        self.noise_floor, self.noise_gain = noise_floor, noise_gain
        unknown = sorted(set(takeover or {}) - set(RingTakeoverRule.__dataclass_fields__))
        if unknown:
            raise ValueError(
                f"env.expert.takeover keys {unknown}: unknown "
                f"(expected some of {sorted(RingTakeoverRule.__dataclass_fields__)})"
            )
        self.takeover = RingTakeoverRule(**(takeover or {}))
        self.peg = torch.tensor(geometry.round_peg_xy, dtype=torch.float32)
        self.phase = torch.zeros(0, dtype=torch.long)
        self.closing = torch.zeros(0, dtype=torch.long)
        self._last_obs: torch.Tensor | None = None
        self._last_command: torch.Tensor | None = None

    # ---------------------------------------------------------------------------- memory
    def reset(self, mask: torch.Tensor) -> None:
        """New episodes start in ``REACH`` where ``mask`` is True."""
        mask = mask.reshape(-1).cpu()
        if self.phase.shape[0] != mask.shape[0]:
            self.phase = torch.zeros(mask.shape[0], dtype=torch.long)
            self.closing = torch.zeros(mask.shape[0], dtype=torch.long)
        self.phase[mask] = Phase.REACH
        self.closing[mask] = 0
        self._last_obs = None

    # ---------------------------------------------------------------------------- acting
    def __call__(self, observation: torch.Tensor, rng: torch.Generator) -> torch.Tensor:
        command = self.command(observation)
        noise_std = self.noise_floor + self.noise_gain * command[:, :3].norm(dim=-1, keepdim=True)
        noise = torch.randn(command.shape[0], 3, generator=rng) * noise_std
        out = command.clone()
        out[:, :3] = out[:, :3] + noise
        return out.clamp(-1.0, 1.0)

    def command(self, observation: torch.Tensor) -> torch.Tensor:
        """The noise-free action ``[N, 6]``; advances the state machine once per new observation."""
        obs = observation.detach().float().cpu().reshape(-1, observation.shape[-1])
        if self._last_obs is not None and self._last_command is not None and torch.equal(obs, self._last_obs):
            return self._last_command.clone()
        if self.phase.shape[0] != obs.shape[0]:
            self.reset(torch.ones(obs.shape[0], dtype=torch.bool))
        command = self._control(obs)
        self._last_obs, self._last_command = obs.clone(), command.clone()
        return command

    def wants_control(
        self, observation: torch.Tensor, policy_action: torch.Tensor, in_control: torch.Tensor
    ) -> torch.Tensor:
        """HG-DAgger: take over near the peg or when the learner's command strays; hand back when it agrees."""
        expert = self.command(observation)
        learner = policy_action.detach().float().cpu().reshape(expert.shape)
        gap = (learner[:, :3] - expert[:, :3]).norm(dim=-1)
        gripper_disagrees = torch.sign(learner[:, 5]) != torch.sign(expert[:, 5])
        state = RingState(observation.detach().float().cpu().reshape(expert.shape[0], -1))
        near_peg = (self.phase == Phase.INSERT) & (
            state.ring_pos[:, 2] - self.g.ring_half_height < self.g.peg_top_z + self.takeover.insert_height
        )
        take = near_peg | (gap > self.takeover.max_gap) | gripper_disagrees
        keep = in_control.reshape(-1).cpu() & (near_peg | (gap > self.takeover.release_gap) | gripper_disagrees)
        return (take | keep).reshape(in_control.shape)

    # ---------------------------------------------------------------------------- the state machine
    def _control(self, obs: torch.Tensor) -> torch.Tensor:
        g, n = self.g, obs.shape[0]
        s = RingState(obs)
        eef = s.eef_pos
        eef_rot = quat_to_matrix(s.eef_quat)
        ring_rot = quat_to_matrix(s.ring_quat)
        ring = s.ring_pos
        offsets = handle_offsets(s, g)  # shared by the handle's position and the grasp check
        handle = handle_position(s, g, offsets)
        handle_yaw = heading(ring_rot)
        eef_yaw = heading(eef_rot)
        grasp_yaw_error = wrap_angle(handle_yaw - eef_yaw, math.pi)  # the gripper is symmetric: modulo pi
        # fingers stopped by the handle: closed but short of fully shut; anywhere along the handle
        held = holds_handle(s, g, offsets)
        ring_over_peg = (ring[:, :2] - self.peg).norm(dim=-1)

        # ---- transitions (a handful of steps at most per call; each reads the current state)
        phase = self.phase
        lost = ((phase == Phase.LIFT) | (phase == Phase.TRANSPORT) | (phase == Phase.INSERT)) & ~held
        phase = torch.where(lost, torch.full_like(phase, Phase.REACH), phase)
        # the robot may have grasped the ring itself while this expert watched (it labels every state and can
        # be handed control anywhere): a firm grasp seen while reaching means the grasp is done, carry on
        firm = held & (s.gripper_qvel[:, 0].abs() < 0.05)
        promoted = firm & ((phase == Phase.REACH) | (phase == Phase.DESCEND))
        phase = torch.where(promoted, torch.full_like(phase, Phase.LIFT), phase)
        self.closing = torch.where(promoted, torch.full_like(self.closing, self.close_steps), self.closing)
        hover = handle + torch.tensor([0.0, 0.0, self.hover_height])
        grasp_z = handle[:, 2] + self.grasp_height
        handle_xy_error = (eef[:, :2] - handle[:, :2]).norm(dim=-1)
        # REACH or DESCEND is a function of the state alone: on the descent column (within 1.5 cm of the handle,
        # between the grasp and the hover height) the gripper descends, wherever it came from. A person handed
        # control there goes on down rather than climbing back to the hover point first, so the label of a state
        # does not depend on who brought the gripper there (hidden memory would teach the learner both moves)
        on_column = (handle_xy_error < 0.015) & (eef[:, 2] < hover[:, 2] + 0.02) & (eef[:, 2] > grasp_z - 0.006)
        approaching = (phase == Phase.REACH) | (phase == Phase.DESCEND)
        phase = torch.where(approaching, torch.where(on_column, Phase.DESCEND.value, Phase.REACH.value), phase)
        at_grasp = (eef[:, 2] - grasp_z).abs() < 0.006
        start_close = (phase == Phase.DESCEND) & at_grasp
        self.closing = torch.where(start_close | (phase == Phase.REACH), torch.zeros_like(self.closing), self.closing)
        phase = torch.where(start_close, torch.full_like(phase, Phase.CLOSE), phase)
        self.closing = self.closing + (phase == Phase.CLOSE).long()
        # wait for the fingers to stop (closed on the handle), at least close_steps and at most twice that
        settled = (s.gripper_qvel[:, 0].abs() < 0.05) & (s.gripper_qpos[:, 0] > GRIPPER_CLOSED_QPOS)
        gripped = (self.closing >= self.close_steps) & settled | (self.closing >= 2 * self.close_steps)
        phase = torch.where((phase == Phase.CLOSE) & gripped, torch.full_like(phase, Phase.LIFT), phase)
        lifted = ring[:, 2] > self.transport_z - 0.015
        phase = torch.where((phase == Phase.LIFT) & lifted, torch.full_like(phase, Phase.TRANSPORT), phase)
        handle_back = wrap_angle(math.pi - handle_yaw).abs() < 0.35
        over = (ring_over_peg < 0.008) & handle_back
        phase = torch.where((phase == Phase.TRANSPORT) & over, torch.full_like(phase, Phase.INSERT), phase)
        drifted = (phase == Phase.INSERT) & (ring_over_peg > 0.02) & (ring[:, 2] - g.ring_half_height > g.peg_top_z)
        phase = torch.where(drifted, torch.full_like(phase, Phase.TRANSPORT), phase)
        threaded = (ring[:, 2] < g.table_z + 0.045) & (ring_over_peg < g.clearance + 0.005)
        carrying = (phase == Phase.LIFT) | (phase == Phase.TRANSPORT) | (phase == Phase.INSERT)
        phase = torch.where(carrying & threaded, torch.full_like(phase, Phase.RELEASE), phase)
        self.phase = phase

        # ---- targets per phase: end-effector position, yaw rate, gripper
        target = eef.clone()
        limit = torch.full((n,), self.speed_max)
        rot_z = torch.zeros(n)
        grip = torch.full((n,), -1.0)
        offset = eef - ring  # the grip: where the gripper holds the ring, relative to its centre

        reach = phase == Phase.REACH
        # rise first when low and far from the handle, so the fingers never sweep the ring or the table
        low = (eef[:, 2] < hover[:, 2] - 0.02) & ((eef[:, :2] - hover[:, :2]).norm(dim=-1) > 0.02)
        reach_target = torch.where(low.unsqueeze(-1), torch.cat([eef[:, :2], hover[:, 2:]], -1), hover)
        target = torch.where(reach.unsqueeze(-1), reach_target, target)
        rot_z = torch.where(reach, grasp_yaw_error, rot_z)

        descend = phase == Phase.DESCEND
        # go down only while lined up over the handle and turned to it; otherwise line up at this height first
        lined_up = (handle_xy_error < 0.010) & (grasp_yaw_error.abs() < self.yaw_tolerance)
        descend_z = torch.where(lined_up, grasp_z, torch.minimum(eef[:, 2], hover[:, 2]))
        target = torch.where(descend.unsqueeze(-1), torch.cat([handle[:, :2], descend_z.unsqueeze(-1)], -1), target)
        rot_z = torch.where(descend, grasp_yaw_error, rot_z)
        limit = torch.where(descend, self._speed((eef[:, 2] - grasp_z).clamp_min(0)), limit)

        close = phase == Phase.CLOSE
        target = torch.where(close.unsqueeze(-1), eef, target)
        grip = torch.where(close, torch.ones(n), grip)

        lift = phase == Phase.LIFT
        lift_target = torch.cat([eef[:, :2], (self.transport_z + offset[:, 2]).unsqueeze(-1)], -1)
        target = torch.where(lift.unsqueeze(-1), lift_target, target)
        grip = torch.where(lift, torch.ones(n), grip)
        limit = torch.where(
            lift, self._speed(ring[:, 2] - g.table_z - g.ring_half_height), limit
        )  # ease it off the table

        carry = phase == Phase.TRANSPORT
        ring_goal = torch.cat([self.peg.expand(n, 2), torch.full((n, 1), self.transport_z)], -1)
        target = torch.where(carry.unsqueeze(-1), ring_goal + offset, target)
        rot_z = torch.where(carry, wrap_angle(math.pi - handle_yaw), rot_z)
        grip = torch.where(carry, torch.ones(n), grip)
        limit = torch.where(carry, self._speed(ring_over_peg + 0.5 * (ring[:, 2] - g.peg_top_z).clamp_min(0)), limit)

        insert = phase == Phase.INSERT
        ring_bottom = ring[:, 2] - g.ring_half_height
        on_peg = ring_bottom < g.peg_top_z - 0.01  # already around the peg: the peg itself keeps it centred
        centred = (ring_over_peg < self.xy_tolerance) | on_peg
        down_z = torch.where(centred, torch.full((n,), g.table_z + g.ring_half_height), ring[:, 2])
        insert_goal = torch.cat([self.peg.expand(n, 2), down_z.unsqueeze(-1)], -1)
        target = torch.where(insert.unsqueeze(-1), insert_goal + offset, target)
        rot_z = torch.where(insert, wrap_angle(math.pi - handle_yaw), rot_z)
        grip = torch.where(insert, torch.ones(n), grip)
        limit = torch.where(insert, self._speed((ring_bottom - g.peg_top_z).abs()), limit)

        release = phase == Phase.RELEASE
        target = torch.where(release.unsqueeze(-1), eef + torch.tensor([0.0, 0.0, 0.02]), target)
        limit = torch.where(release, torch.full((n,), self.speed_min), limit)

        # ---- action: proportional translation under the phase's speed limit, yaw, tilt hold, gripper
        move = self.gain * (target - eef)
        norm = move.norm(dim=-1, keepdim=True)
        move = move * torch.clamp(limit.unsqueeze(-1) / norm.clamp_min(1e-9), max=1.0)
        yaw = (self.yaw_gain * rot_z / g.max_rotation).clamp(-1.0, 1.0)
        tilt = (self.tilt_gain * tilt_correction(eef_rot)[:, 1] / g.max_rotation).clamp(-1.0, 1.0)
        return torch.cat([move, tilt.unsqueeze(-1), yaw.unsqueeze(-1), grip.unsqueeze(-1)], -1).clamp(-1.0, 1.0)

    def _speed(self, distance: torch.Tensor) -> torch.Tensor:
        """Speed limit (action units) at ``distance`` (m) from the phase's constraint: slow where it is close."""
        return self.speed_min + (self.speed_max - self.speed_min) * (1 - torch.exp(-distance / self.speed_distance))
