"""The 2D aperture-passing task (paper section V-A) as a native, batched TorchRL environment.

State: the agent's centre (x, y) in cm. Action: velocity (vx, vy) in cm/step, each component
bounded by ``max_speed``. An episode fails on wall contact, on leaving the arena or after
``max_steps`` steps, and succeeds when the centre enters the goal rectangle without contact.
"""

from __future__ import annotations

from typing import Any, Mapping

import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.envs import EnvBase

from dpiil_rl.envs.aperture_geometry import ApertureGeometry
from dpiil_rl.envs.task_specs import reset_frame, reset_mask, set_task_specs


class ApertureEnv(EnvBase):
    """Batched aperture-passing env (``batch_size=[num_envs]``) with partial resets.

    Besides ``observation`` the env writes per-step outcome flags ``success``, ``collision`` and
    ``out_of_bounds`` so collectors can tell why an episode ended.
    """

    # a class constant over EnvBase's read-only property, as TorchRL's own envs declare it
    batch_locked = True  # pyright: ignore[reportAssignmentType]
    position_key = "observation"  # the position part of the state used for the speed f_v
    observation_parts = {"position": slice(0, 2)}  # the named parts of the state (the centre is all of it)

    def __init__(
        self,
        geometry: ApertureGeometry,
        num_envs: int = 1,
        device: str | torch.device = "cpu",
        seed: int | None = None,
        expert: Mapping[str, Any] | None = None,
    ) -> None:
        if int(num_envs) < 1:
            raise ValueError(f"num_envs = {num_envs}: expected at least one environment")
        super().__init__(device=device, batch_size=torch.Size([int(num_envs)]))
        self.geometry = geometry
        self.expert_config = dict(expert or {})
        self._rects = geometry.rectangles().to(self.device)
        n = int(num_envs)
        x0, y0, x1, y1 = geometry.arena
        reach = geometry.max_speed * 2**0.5  # farthest a single step can carry the centre outside the arena
        set_task_specs(
            self,
            {"observation": (torch.tensor([x0 - reach, y0 - reach]), torch.tensor([x1 + reach, y1 + reach]))},
            geometry.max_steps,
            ("success", "collision", "out_of_bounds"),
            action=(torch.full((2,), -geometry.max_speed), torch.full((2,), geometry.max_speed)),
        )
        self._position = torch.zeros(n, 2, device=self.device)
        self._steps = torch.zeros(n, 1, dtype=torch.int64, device=self.device)
        self.rng = torch.Generator(device=self.device)
        self._set_seed(0 if seed is None else int(seed))

    # ----------------------------------------------------------------------------- EnvBase API
    def _set_seed(self, seed: int | None) -> None:
        self.rng.manual_seed(0 if seed is None else int(seed))

    def _reset(self, tensordict: TensorDictBase | None, **kwargs: Any) -> TensorDictBase:
        n = self.batch_size[0]
        mask = reset_mask(self, tensordict)
        g = self.geometry
        noise = (torch.rand(n, 2, generator=self.rng, device=self.device) * 2 - 1) * g.start_noise
        start = torch.tensor(g.start_center, device=self.device) + noise
        self._position = torch.where(mask.unsqueeze(-1), start, self._position)
        self._steps = torch.where(mask.unsqueeze(-1), torch.zeros_like(self._steps), self._steps)
        return reset_frame(self, {"observation": self._position}, self._steps)

    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        g = self.geometry
        action = tensordict.get("action").clamp(-g.max_speed, g.max_speed)
        p0 = self._position
        p1 = p0 + action
        collision = g.segment_collides(p0, p1, self._rects)
        out = ~g.in_arena(p1)
        success = g.in_goal(p1) & ~collision & ~out
        self._position = p1
        self._steps = self._steps + 1
        terminated = (collision | out | success).unsqueeze(-1)
        truncated = (self._steps >= g.max_steps) & ~terminated
        return TensorDict(
            {
                "observation": p1.clone(),
                "step_count": self._steps.clone(),
                "success": success.unsqueeze(-1),
                "collision": collision.unsqueeze(-1),
                "out_of_bounds": out.unsqueeze(-1),
                "reward": success.unsqueeze(-1).float(),
                "done": terminated | truncated,
                "terminated": terminated,
                "truncated": truncated,
            },
            batch_size=self.batch_size,
            device=self.device,
        )

    # ----------------------------------------------------------------------------- helpers
    def draw_background(self, ax: Any) -> None:
        """Capability used by the 2D map plots: draw the task's walls, goal and start region."""
        draw_aperture_background(self.geometry, ax)


def build_aperture_env(
    num_envs: int = 1,
    seed: int | None = None,
    device: str = "cpu",
    expert: Mapping[str, Any] | None = None,
    **geometry: Any,
) -> ApertureEnv:
    """Hydra target of ``configs/env/aperture.yaml``: validates the geometry and builds the env."""
    geometry.pop("name", None)
    return ApertureEnv(
        ApertureGeometry.from_mapping(geometry), num_envs=num_envs, device=device, seed=seed, expert=expert
    )


def draw_aperture_background(geometry: ApertureGeometry, ax: Any) -> None:
    """Walls (grey), goal (green) and start square (dashed) on a matplotlib axis, in cm."""
    from matplotlib.patches import Rectangle

    for x0, y0, x1, y1 in geometry.rectangles().tolist():
        ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, color="0.45", zorder=3))
    gx0, gy0, gx1, gy1 = geometry.goal
    ax.add_patch(Rectangle((gx0, gy0), gx1 - gx0, gy1 - gy0, fill=False, ec="tab:green", lw=1.5, zorder=3))
    cx, cy = geometry.start_center
    s = geometry.start_noise
    ax.add_patch(Rectangle((cx - s, cy - s), 2 * s, 2 * s, fill=False, ec="k", ls="--", lw=1.0, zorder=3))
    ax0, ay0, ax1, ay1 = geometry.arena
    ax.set_xlim(ax0, ax1)
    ax.set_ylim(ay0, ay1)
    ax.set_aspect("equal")
