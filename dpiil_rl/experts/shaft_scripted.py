"""A scripted careful person for the arm-reaching tasks (``shaft``, ``ring_real``; docs/design.md, "Tasks").

A pure state-feedback policy on the 12-D state (correct from any state a learner reaches, so it can
label every state). It steers the controlled point (TCP + the task's ``tool_offset``) to an aim point in
the goal region through a *funnel* of gates, the person's plan of the approach: below a gate's height
the point must be inside the gate's corridor (half-widths around the aim point's vertical axis), else
the arm or what it holds meets an obstacle (a plate, the shaft, the peg).

* Above a gate, the point moves toward the aim point's axis and descends only to ``margin`` above the gate
  until it is aligned (within ``align_fraction`` of the corridor), then goes on down.
* Inside a corridor but off its axis, it holds its height and re-centres (sideways moves are safe there).
* Outside a corridor and low (near a ramp that rises to the gate's height within ``band`` of the corridor),
  it rises first and moves sideways only as it clears the ramp (fully ``ramp_softness`` above it): no
  sweeping into an obstacle.

The command is proportional (``gain``) toward that target, its speed limited by a smooth increasing
function of the clearance: the distance from the gripper's boxes (``tool_boxes``) to the nearest scene
box (table, obstacles, target), or to the aim point if closer; fast in the open, slow in the channel and
near the target. Gaussian noise with a standard deviation growing with the commanded speed is added
(signal-dependent noise).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np
import torch

from dpiil_rl.envs.shaft_task import STATE_SLICES, ShaftTask


@dataclass(frozen=True)
class Gate:
    """Below ``height`` (m above the aim point) the controlled point must stay within ``half_width`` (x, y; m)
    of the aim point's vertical axis; the obstacle that makes it so reaches ``band`` (m) beyond the corridor."""

    height: float
    half_width: tuple[float, float]
    band: float

    @classmethod
    def from_mapping(cls, spec: Mapping[str, Any], where: str) -> "Gate":
        spec = dict(spec)
        unknown = sorted(set(spec) - {"height", "half_width", "band"})
        if unknown:
            raise ValueError(f"{where}.{unknown[0]}: unknown key (expected height, half_width, band)")
        width = tuple(float(v) for v in spec.get("half_width", ()))
        if len(width) != 2 or any(not w > 0 for w in width):
            raise ValueError(f"{where}.half_width = {list(width)}: expected [x, y], two positive half-widths (m)")
        band = float(spec.get("band", 0.0))
        if band < 0:
            raise ValueError(f"{where}.band = {band}: expected a width >= 0 (m)")
        return cls(height=float(spec["height"]), half_width=(width[0], width[1]), band=band)


@dataclass(frozen=True)
class ShaftTakeoverRule:
    """HG-DAgger: when this expert, supervising the robot, grabs control and hands it back."""

    max_gap: float = 0.3  # take over when the learner's action differs from the expert's by this (action units)
    narrow_clearance: float = 0.02  # ... or wherever the clearance is below this (m): it does the narrow part itself
    release_gap: float = 0.1  # hand back only when the learner agrees within this
    release_clearance: float = 0.04  # ... and the clearance exceeds this (m)


class ShaftScriptedPolicy:
    """Vectorised risk-sensitive expert for :class:`~dpiil_rl.envs.shaft.ShaftEnv` (3-D actions in [-1, 1])."""

    def __init__(
        self,
        geometry: ShaftTask,
        speed_max: float,
        speed_min: float,
        clearance_scale: float,
        gain: float,
        gates: Mapping[str, Mapping[str, Any]] | Sequence[Mapping[str, Any]],
        margin: float,
        align_fraction: float,
        ramp_slope: float,
        ramp_softness: float,
        tool_boxes: Mapping[str, Mapping[str, Sequence[float]]],
        noise_floor: float,
        noise_gain: float,
        aim: Sequence[float] = (0.0, 0.0, 0.0),
        takeover: Mapping[str, float] | None = None,
    ) -> None:
        if not 0 < speed_min <= speed_max <= 1:
            raise ValueError(
                f"env.expert speed_min = {speed_min}, speed_max = {speed_max}: expected 0 < min <= max <= 1"
            )
        for name, value in {
            "clearance_scale": clearance_scale,
            "gain": gain,
            "ramp_softness": ramp_softness,
            "ramp_slope": ramp_slope,
        }.items():
            if not value > 0:
                raise ValueError(f"env.expert.{name} = {value}: expected a positive number")
        if not 0 < align_fraction <= 1:
            raise ValueError(f"env.expert.align_fraction = {align_fraction}: expected a fraction in (0, 1]")
        for name, value in {"margin": margin, "noise_floor": noise_floor, "noise_gain": noise_gain}.items():
            if value < 0:
                raise ValueError(f"env.expert.{name} = {value}: expected a number >= 0")
        items = gates.items() if isinstance(gates, Mapping) else enumerate(gates)
        parsed = [Gate.from_mapping(spec, f"env.expert.gates.{name}") for name, spec in items]
        if not parsed:
            raise ValueError("env.expert.gates: empty (expected at least one gate above the aim point)")
        aim_v = np.array([float(v) for v in aim])
        if aim_v.shape != (3,):
            raise ValueError(f"env.expert.aim = {list(aim)}: expected [dx, dy, dz] (m) from the goal point")
        if (
            np.hypot(aim_v[0], aim_v[1]) > geometry.goal_radius
            or not geometry.goal_depth[0] <= aim_v[2] <= geometry.goal_depth[1]
        ):
            raise ValueError(f"env.expert.aim = {list(aim)}: expected a point inside the goal region (env.goal)")
        boxes = []
        for name, box in (tool_boxes or {}).items():
            centre = [float(v) for v in box.get("centre", ())]
            half = [float(v) for v in box.get("half", ())]
            if len(centre) != 3 or len(half) != 3 or any(not h > 0 for h in half):
                raise ValueError(
                    f"env.expert.tool_boxes.{name} = {dict(box)}: "
                    "expected centre [x, y, z] and half [hx, hy, hz] > 0 (m)"
                )
            boxes.append(centre + half)
        if not boxes:
            raise ValueError("env.expert.tool_boxes: empty (expected the gripper's boxes relative to the TCP)")
        unknown = sorted(set(takeover or {}) - set(ShaftTakeoverRule.__dataclass_fields__))
        if unknown:
            raise ValueError(
                f"env.expert.takeover.{unknown[0]}: unknown key "
                f"(expected some of {sorted(ShaftTakeoverRule.__dataclass_fields__)})"
            )
        self.g = geometry
        self.geometry = geometry
        self.speed_max, self.speed_min = float(speed_max), float(speed_min)
        self.clearance_scale, self.gain = float(clearance_scale), float(gain)
        self.margin, self.align_fraction = float(margin), float(align_fraction)
        self.ramp_slope, self.ramp_softness = float(ramp_slope), float(ramp_softness)
        self.noise_floor, self.noise_gain = float(noise_floor), float(noise_gain)
        self.takeover = ShaftTakeoverRule(**dict(takeover or {}))
        self.gates = parsed
        # numpy for the per-step arithmetic: a few dozen operations on [N, 3] arrays, cheaper than torch's dispatch
        self._heights = np.array([gate.height for gate in parsed])
        self._widths = np.array([gate.half_width for gate in parsed])
        self._bands = np.array([gate.band for gate in parsed])
        self._tool = np.array(boxes, dtype=np.float64)  # [B, 6] relative to the TCP
        self._obstacles = geometry.scene.boxes()  # [K, 6] table and objects
        self._offset = np.array(geometry.tool_offset, dtype=np.float64)
        self._aim = np.array(geometry.goal_offset, dtype=np.float64) + aim_v  # from the target's centre

    # ------------------------------------------------------------------------------ pieces
    def aim_point(self, observation: torch.Tensor) -> torch.Tensor:
        """Where the controlled point is steered ``[N, 3]``: the target (as observed) + goal offset + aim."""
        obs = _numpy(observation)
        return torch.from_numpy(obs[:, STATE_SLICES["target"]] + self._aim).float()

    def clearance(self, tcp: torch.Tensor | np.ndarray) -> torch.Tensor:
        """Distance ``[N]`` (m) from the gripper's boxes at TCP positions ``[N, 3]`` to the nearest scene box."""
        return torch.from_numpy(self._clearance(_numpy(tcp))).float()

    def _clearance(self, tcp: np.ndarray) -> np.ndarray:
        tool, obstacles = self._tool, self._obstacles
        centres = tcp[:, None, :] + tool[None, :, :3]  # [N, B, 3]
        gap = np.abs(centres[:, :, None, :] - obstacles[None, None, :, :3])  # [N, B, K, 3]
        gap = np.maximum(gap - tool[None, :, None, 3:] - obstacles[None, None, :, 3:], 0.0)
        return np.sqrt((gap * gap).sum(-1)).min(axis=(1, 2))

    def speed(self, clearance: torch.Tensor | np.ndarray) -> torch.Tensor | np.ndarray:
        """Commanded speed (action units) at ``clearance`` (m): a smooth, increasing function."""
        if isinstance(clearance, torch.Tensor):
            return torch.from_numpy(self.speed(clearance.double().numpy())).float()  # type: ignore[arg-type]
        return self.speed_min + (self.speed_max - self.speed_min) * (
            1 - np.exp(-np.maximum(clearance, 0.0) / self.clearance_scale)
        )

    def command(self, observation: torch.Tensor) -> torch.Tensor:
        """The noise-free action ``[N, 3]`` at states ``[N, 12]``."""
        return torch.from_numpy(self._command(_numpy(observation))).float()

    def _command(self, obs: np.ndarray) -> np.ndarray:
        tcp = obs[:, STATE_SLICES["tcp"]]
        error = tcp + self._offset - (obs[:, STATE_SLICES["target"]] + self._aim)  # [N, 3]
        height = error[:, 2:3]  # [N, 1]
        ax, ay = np.abs(error[:, 0:1]), np.abs(error[:, 1:2])
        wx, wy = self._widths[:, 0], self._widths[:, 1]  # [G]
        inside = (ax <= wx) & (ay <= wy)  # [N, G]
        aligned = (ax <= self.align_fraction * wx) & (ay <= self.align_fraction * wy)
        excess = np.maximum(np.maximum(ax - wx, ay - wy), 0.0)
        ramp = self._heights - self.ramp_slope * np.maximum(excess - self._bands, 0.0)
        ramp = np.where(inside, -np.inf, ramp).max(-1, keepdims=True)
        stop = np.broadcast_to(self._heights + self.margin, inside.shape)
        floor = np.where(inside & (height < stop), height, stop)  # inside a corridor, off its axis: hold the height
        floor = np.where(aligned, -np.inf, floor).max(-1, keepdims=True)
        target_height = np.maximum(floor, 0.0)
        sideways = np.clip(
            (height - ramp) / self.ramp_softness, 0.0, 1.0
        )  # none at or below the ramp, full above it + softness
        velocity = np.concatenate(
            [-self.gain * error[:, :2] * sideways, self.gain * (target_height - height)], -1
        )  # m/s
        clearance = np.minimum(self._clearance(tcp), np.sqrt((error * error).sum(-1)))
        limit = self.speed(clearance) * self.g.max_speed  # m/s
        norm = np.sqrt((velocity * velocity).sum(-1))
        velocity = velocity * np.minimum(limit / np.maximum(norm, 1e-9), 1.0)[:, None]
        return np.clip(velocity / self.g.max_speed, -1.0, 1.0)

    # ------------------------------------------------------------------------------ acting
    def __call__(self, observation: torch.Tensor, generator: torch.Generator | None = None) -> torch.Tensor:
        """Noisy action ``[N, 3]``: the command plus Gaussian noise with std
        ``noise_floor + noise_gain * |command|``."""
        command = self.command(observation)
        std = self.noise_floor + self.noise_gain * command.norm(dim=-1, keepdim=True)
        noise = torch.randn(command.shape, generator=generator) * std
        return (command + noise).clamp(-1.0, 1.0).reshape(*observation.shape[:-1], 3)

    def wants_control(
        self, observation: torch.Tensor, learner_action: torch.Tensor, in_control: torch.Tensor
    ) -> torch.Tensor:
        """HG-DAgger: take over where the learner's command strays or the clearance is narrow; hand back when
        the learner agrees in the open."""
        rule = self.takeover
        obs = _numpy(observation)
        expert = torch.from_numpy(self._command(obs)).float()
        gap = (learner_action.detach().float().cpu().reshape(expert.shape) - expert).norm(dim=-1)
        clearance = torch.from_numpy(self._clearance(obs[:, STATE_SLICES["tcp"]]))
        held = in_control.detach().cpu().reshape(-1).bool()
        take = (gap > rule.max_gap) | (clearance < rule.narrow_clearance)
        keep = held & ((gap > rule.release_gap) | (clearance < rule.release_clearance))
        return (take | keep).reshape(in_control.shape)


def _numpy(values: torch.Tensor | np.ndarray) -> np.ndarray:
    """``[N, D]`` float64 numpy array of a batch (or a single row) of states or positions."""
    if isinstance(values, torch.Tensor):
        values = values.detach().cpu().double().numpy()
    array = np.asarray(values, dtype=np.float64)
    return array.reshape(-1, array.shape[-1])
