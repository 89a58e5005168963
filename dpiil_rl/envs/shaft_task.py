"""The arm-reaching tasks' fixed facts (paper section VI): scene, start, goal and state layout.

Plain data (no MuJoCo import), shared by the env, the scripted expert and the plots. One dataclass
serves both real-robot tasks of the paper, which differ only in their numbers:

* ``shaft``: reach the grasp position at a shaft standing in a narrow channel between two plates;
* ``ring_real``: thread the ring held at the TCP down a peg (2 mm radial clearance), past a second peg.

The *controlled point* is the TCP plus ``tool_offset`` (base axes, orientation held): the TCP itself for
the shaft, the centre of the held ring for ring threading. The episode succeeds when the controlled point
enters the goal region: within ``goal_radius`` of the goal's vertical axis and within ``goal_depth``
(a z range) of the goal point, which is the target's centre plus ``goal_offset``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np
import torch

from dpiil_rl.robots.sim_scene import Scene

#: the 12-D state, in order: (name, size)
STATE_LAYOUT: tuple[tuple[str, int], ...] = (("joints", 6), ("tcp", 3), ("target", 3))
STATE_SLICES: dict[str, slice] = {"joints": slice(0, 6), "tcp": slice(6, 9), "target": slice(9, 12)}
STATE_DIM = 12


def _vector(value: Any, size: int, where: str) -> tuple[float, ...]:
    values = tuple(float(v) for v in (value if value is not None else ()))
    if len(values) != size:
        raise ValueError(f"{where} = {list(values)}: expected {size} numbers")
    return values


def _bounds(value: Any, size: int, where: str) -> tuple[tuple[float, ...], tuple[float, ...]]:
    if value is None or len(value) != 2:
        raise ValueError(f"{where} = {value!r}: expected [[low ...], [high ...]] with {size} numbers each")
    low, high = _vector(value[0], size, f"{where}[0]"), _vector(value[1], size, f"{where}[1]")
    if any(lo >= hi for lo, hi in zip(low, high)):
        raise ValueError(f"{where} = {[list(low), list(high)]}: expected low < high in every dimension")
    return low, high


@dataclass(frozen=True)
class ShaftTask:
    """Validated task description; build it with :meth:`from_mapping` from the env config."""

    scene: Scene
    start_position: tuple[float, float, float]  # nominal start of the TCP (base frame, m)
    start_noise: float  # the start is perturbed by U(-noise, noise) per axis (m)
    reset_speed: float  # TCP speed of the move to the start (m/s; a simulation teleports)
    goal_offset: tuple[float, float, float]  # goal point = target centre + this (m)
    goal_radius: float  # lateral tolerance around the goal's vertical axis (m)
    goal_depth: tuple[float, float]  # z range of the goal region relative to the goal point (m)
    tool_offset: tuple[float, float, float]  # controlled point = TCP + this (base axes, m)
    max_speed: float  # TCP speed per axis at action 1 (m/s)
    acceleration: float  # bound on the TCP's change of velocity (m/s^2)
    max_steps: int  # horizon (control periods)
    workspace_low: tuple[float, float, float]  # the TCP leaving this box ends the episode (a failure)
    workspace_high: tuple[float, float, float]
    joint_low: tuple[float, ...]  # joint angle bounds of the state (rad; specs, normalisation)
    joint_high: tuple[float, ...]
    collision_ends_episode: bool = True  # contact is a failure that ends the episode (else it is counted)

    @classmethod
    def from_mapping(cls, spec: Mapping[str, Any]) -> "ShaftTask":
        spec = dict(spec)
        known = {
            "scene",
            "start",
            "goal",
            "tool_offset",
            "max_speed",
            "acceleration",
            "max_steps",
            "workspace",
            "joint_bounds",
            "collision_ends_episode",
        }
        unknown = sorted(set(spec) - known)
        if unknown:
            raise ValueError(f"env.{unknown[0]}: unknown key (expected some of {sorted(known)})")
        missing = sorted(known - set(spec) - {"collision_ends_episode", "tool_offset"})
        if missing:
            raise ValueError(f"env.{missing[0]}: missing (configs/env/shaft.yaml lists every key)")
        scene = Scene.from_mapping(spec["scene"], "env.scene")
        start = dict(spec["start"])
        goal = dict(spec["goal"])
        low, high = _bounds(spec["workspace"], 3, "env.workspace")
        joint_low, joint_high = _bounds(spec["joint_bounds"], 6, "env.joint_bounds")
        depth = _vector(goal.get("depth"), 2, "env.goal.depth")
        task = cls(
            scene=scene,
            start_position=_vector(start.get("position"), 3, "env.start.position"),  # type: ignore[arg-type]
            start_noise=float(start.get("noise", 0.0)),
            reset_speed=float(start.get("reset_speed", 0.1)),
            goal_offset=_vector(goal.get("offset"), 3, "env.goal.offset"),  # type: ignore[arg-type]
            goal_radius=float(goal.get("radius", 0.0)),
            goal_depth=(depth[0], depth[1]),
            tool_offset=_vector(spec.get("tool_offset", (0.0, 0.0, 0.0)), 3, "env.tool_offset"),  # type: ignore[arg-type]
            max_speed=float(spec["max_speed"]),
            acceleration=float(spec["acceleration"]),
            max_steps=int(spec["max_steps"]),
            workspace_low=low,  # type: ignore[arg-type]
            workspace_high=high,  # type: ignore[arg-type]
            joint_low=joint_low,
            joint_high=joint_high,
            collision_ends_episode=bool(spec.get("collision_ends_episode", True)),
        )
        task._check()
        return task

    def _check(self) -> None:
        for name in ("max_speed", "acceleration", "goal_radius", "reset_speed"):
            if not getattr(self, name) > 0:
                raise ValueError(f"env.{_key(name)} = {getattr(self, name)}: expected a positive number")
        if self.start_noise < 0:
            raise ValueError(f"env.start.noise = {self.start_noise}: expected a half-width >= 0 (m)")
        if self.max_steps < 1:
            raise ValueError(f"env.max_steps = {self.max_steps}: expected a positive horizon")
        if not self.goal_depth[0] < self.goal_depth[1]:
            raise ValueError(
                f"env.goal.depth = {list(self.goal_depth)}: expected [below, above] with below < above (m)"
            )
        low, high = np.array(self.workspace_low), np.array(self.workspace_high)
        start = np.array(self.start_position)
        if np.any(start - self.start_noise <= low) or np.any(start + self.start_noise >= high):
            raise ValueError(
                f"env.start.position = {list(self.start_position)} ± {self.start_noise}: expected the start box inside "
                f"env.workspace = {[list(self.workspace_low), list(self.workspace_high)]}"
            )
        if np.any(self.target_position <= low) or np.any(self.target_position >= high):
            raise ValueError(
                f"env.scene: the target's centre {self.target_position.round(4).tolist()} is outside env.workspace "
                "(the state reports it within the workspace bounds)"
            )
        goal_tcp = self.goal_position - np.array(self.tool_offset)
        if np.any(goal_tcp <= low) or np.any(goal_tcp >= high):
            raise ValueError(
                f"env.goal.offset = {list(self.goal_offset)}: the TCP at the goal {goal_tcp.round(4).tolist()} "
                "is outside env.workspace"
            )

    # ------------------------------------------------------------------------------ geometry
    @property
    def target_position(self) -> np.ndarray:
        """Centre of the target object (shaft, peg), base frame."""
        return np.array(self.scene.target.pos, dtype=np.float64)

    @property
    def goal_position(self) -> np.ndarray:
        """The goal point of the controlled point, base frame."""
        return self.target_position + np.array(self.goal_offset)

    def controlled_point(self, tcp: torch.Tensor) -> torch.Tensor:
        """The controlled point ``[..., 3]`` for TCP positions ``[..., 3]``."""
        return tcp + torch.tensor(self.tool_offset, dtype=tcp.dtype, device=tcp.device)

    def in_goal(self, tcp: torch.Tensor) -> torch.Tensor:
        """Whether the controlled point of TCP positions ``[..., 3]`` is in the goal region (``[...]`` bool)."""
        error = self.controlled_point(tcp) - torch.tensor(self.goal_position, dtype=tcp.dtype, device=tcp.device)
        lateral = torch.linalg.vector_norm(error[..., :2], dim=-1)
        return (
            (lateral <= self.goal_radius)
            & (error[..., 2] >= self.goal_depth[0])
            & (error[..., 2] <= self.goal_depth[1])
        )

    def in_workspace(self, tcp: torch.Tensor) -> torch.Tensor:
        low = torch.tensor(self.workspace_low, dtype=tcp.dtype, device=tcp.device)
        high = torch.tensor(self.workspace_high, dtype=tcp.dtype, device=tcp.device)
        return ((tcp >= low) & (tcp <= high)).all(-1)

    # ------------------------------------------------------------------------------ state
    def observation_bounds(self) -> tuple[torch.Tensor, torch.Tensor]:
        """Per-dimension ``(low, high)`` of the 12-D state: joint bounds, workspace (TCP), workspace (target).

        The env clips the state into them: the TCP leaves the workspace only on the step that ends the episode.
        """
        low = [*self.joint_low, *self.workspace_low, *self.workspace_low]
        high = [*self.joint_high, *self.workspace_high, *self.workspace_high]
        return torch.tensor(low, dtype=torch.float32), torch.tensor(high, dtype=torch.float32)


def _key(field: str) -> str:
    return {"goal_radius": "goal.radius", "reset_speed": "start.reset_speed"}.get(field, field)
