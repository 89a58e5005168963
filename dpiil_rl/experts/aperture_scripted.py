"""A scripted careful person for the aperture task (docs/design.md, "Tasks").

It plans once on a navigation grid: a Dijkstra distance-to-goal field where each cm of path costs
more the closer it runs to a wall, so optimal paths keep to the middle of apertures. At run time
it is a pure state-feedback policy (correct from any state a learner may reach): the direction is
the descent direction of that field, the speed a smooth increasing function of clearance (fast in
the open, slow in narrow gaps), and the action carries Gaussian noise whose standard deviation
grows with the commanded speed (signal-dependent noise, Harris & Wolpert 1998).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any, Mapping

import numpy as np
import torch
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from dpiil_rl.envs.aperture_geometry import ApertureGeometry


@dataclass(frozen=True)
class TakeoverRule:
    """When this expert, supervising the robot (HG-DAgger), grabs control and when it hands it back."""

    lookahead_steps: int = 4  # the learner's command is rolled forward this many steps
    margin: float = 0.15  # take over if that roll-out comes closer than this to a wall (cm of clearance)
    max_angle_deg: float = 60.0  # ... or the command points this far away from the expert's own direction
    min_speed_ratio: float = 0.25  # ... or the command is slower than this fraction of the expert's speed
    narrow_clearance: float = 0.0  # ... or the agent is somewhere this narrow (cm of clearance): a conservative expert
    release_clearance: float = 1.0  # hand back only where the clearance exceeds this (cm): conservative
    release_angle_deg: float = 25.0  # ... and the learner's command agrees with the expert's within this angle

    def __post_init__(self) -> None:
        if int(self.lookahead_steps) < 1:
            raise ValueError(f"env.expert.takeover.lookahead_steps = {self.lookahead_steps}: expected >= 1")
        for name in ("max_angle_deg", "release_angle_deg"):
            v = getattr(self, name)
            if not 0.0 < v <= 180.0:
                raise ValueError(f"env.expert.takeover.{name} = {v}: expected an angle in (0, 180] degrees")
        for name in ("margin", "min_speed_ratio", "narrow_clearance", "release_clearance"):
            if getattr(self, name) < 0:
                raise ValueError(f"env.expert.takeover.{name} = {getattr(self, name)}: expected a number >= 0")


class ApertureScriptedPolicy:
    """Vectorised risk-sensitive expert for :class:`~dpiil_rl.envs.aperture.ApertureEnv`."""

    def __init__(
        self,
        geometry: ApertureGeometry,
        speed_max: float,
        speed_min: float,
        clearance_scale: float,
        noise_floor: float,
        noise_gain: float,
        grid_resolution: float = 0.1,
        centering_weight: float = 0.3,
        takeover: Mapping[str, Any] | None = None,  # TakeoverRule's fields
    ) -> None:
        for name, value in {
            "speed_max": speed_max,
            "speed_min": speed_min,
            "clearance_scale": clearance_scale,
            "grid_resolution": grid_resolution,
        }.items():
            if value <= 0:
                raise ValueError(f"env.expert.{name} = {value}: expected a positive number")
        for name, value in {
            "noise_floor": noise_floor,
            "noise_gain": noise_gain,
            "centering_weight": centering_weight,
        }.items():
            if value < 0:
                raise ValueError(f"env.expert.{name} = {value}: expected a number >= 0")
        if speed_min > speed_max:
            raise ValueError(f"env.expert.speed_min = {speed_min}: expected <= speed_max = {speed_max}")
        if speed_max > geometry.max_speed:
            raise ValueError(f"env.expert.speed_max = {speed_max}: expected <= env.max_speed = {geometry.max_speed}")
        self.geometry = geometry
        self.speed_max = float(speed_max)
        self.speed_min = float(speed_min)
        self.clearance_scale = float(clearance_scale)
        self.noise_floor = float(noise_floor)
        self.noise_gain = float(noise_gain)
        self.h = float(grid_resolution)
        self.centering_weight = float(centering_weight)
        known = {f.name for f in fields(TakeoverRule)}
        unknown = sorted(set(takeover or {}) - known)
        if unknown:
            raise ValueError(f"env.expert.takeover.{unknown[0]}: unknown key (expected some of {sorted(known)})")
        self.takeover = TakeoverRule(**dict(takeover or {}))
        self._rects = geometry.rectangles()
        self.field = torch.from_numpy(self._plan()).float()  # [nx, ny] cost-to-goal at cell centres
        self._table = self._tabulate()  # [nx, ny, 3]: unit direction (2) and nominal speed at cell centres

    # ------------------------------------------------------------------------------ planning
    def _plan(self) -> np.ndarray:
        x0, y0, x1, y1 = self.geometry.arena
        nx, ny = int(math.ceil((x1 - x0) / self.h)), int(math.ceil((y1 - y0) / self.h))
        self._nx, self._ny = nx, ny
        xs = x0 + (np.arange(nx) + 0.5) * self.h
        ys = y0 + (np.arange(ny) + 0.5) * self.h
        centres = torch.from_numpy(np.stack(np.meshgrid(xs, ys, indexing="ij"), -1)).float()  # [nx, ny, 2]
        clearance = self.geometry.clearance(centres.reshape(-1, 2), self._rects).reshape(nx, ny).numpy()
        free = clearance > 0.02
        cost = 1.0 + self.centering_weight / np.maximum(clearance, 0.05)
        idx = np.arange(nx * ny).reshape(nx, ny)
        rows, cols, weights = [], [], []
        for di, dj in ((1, 0), (0, 1), (1, 1), (1, -1)):
            i_lo, i_hi = max(0, -di), nx - max(0, di)
            j_lo, j_hi = max(0, -dj), ny - max(0, dj)
            a = idx[i_lo:i_hi, j_lo:j_hi]
            b = idx[i_lo + di : i_hi + di, j_lo + dj : j_hi + dj]
            ok = free.reshape(-1)[a.reshape(-1)] & free.reshape(-1)[b.reshape(-1)]
            length = self.h * math.hypot(di, dj)
            w = length * 0.5 * (cost.reshape(-1)[a.reshape(-1)] + cost.reshape(-1)[b.reshape(-1)])
            rows.append(a.reshape(-1)[ok])
            cols.append(b.reshape(-1)[ok])
            weights.append(w[ok])
        graph = coo_matrix(
            (np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))), shape=(nx * ny, nx * ny)
        ).tocsr()
        in_goal = self.geometry.in_goal(centres).numpy() & free
        if not in_goal.any():
            raise ValueError(f"env.goal = {list(self.geometry.goal)}: no free space for the agent inside the goal")
        dist = dijkstra(graph, directed=False, indices=idx[in_goal], min_only=True)
        field = dist.reshape(nx, ny)
        reachable = np.isfinite(field)
        start = torch.tensor([self.geometry.start_center]).float()
        si, sj = self._cell(start)
        if not reachable[int(si), int(sj)]:
            raise ValueError(
                "env: the goal cannot be reached from env.start by the agent (an aperture or passage is "
                f"blocked at grid resolution {self.h} cm); expected a free route"
            )
        # Unreachable cells (walls) become a high plateau so the descent direction points away from them.
        field[~reachable] = field[reachable].max() * 1.5 + 10.0
        return field

    def _cell(self, p: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        x0, y0, _, _ = self.geometry.arena
        fi = ((p[..., 0] - x0) / self.h - 0.5).clamp(0, self._nx - 1)
        fj = ((p[..., 1] - y0) / self.h - 0.5).clamp(0, self._ny - 1)
        return fi, fj

    def _bilinear(self, grid: torch.Tensor, p: torch.Tensor) -> torch.Tensor:
        """Bilinear interpolation of a cell-centre grid ``[nx, ny, ...]`` at positions ``[..., 2]``."""
        fi, fj = self._cell(p)
        i0 = fi.floor().long().clamp(0, self._nx - 2)
        j0 = fj.floor().long().clamp(0, self._ny - 2)
        ti, tj = fi - i0, fj - j0
        extra = grid.dim() - 2
        ti, tj = ti.reshape(*ti.shape, *([1] * extra)), tj.reshape(*tj.shape, *([1] * extra))
        return (
            grid[i0, j0] * (1 - ti) * (1 - tj)
            + grid[i0 + 1, j0] * ti * (1 - tj)
            + grid[i0, j0 + 1] * (1 - ti) * tj
            + grid[i0 + 1, j0 + 1] * ti * tj
        )

    def cost_to_go(self, p: torch.Tensor) -> torch.Tensor:
        """Bilinear interpolation of the planned cost-to-goal at positions ``[..., 2]``."""
        return self._bilinear(self.field, p)

    def _tabulate(self) -> torch.Tensor:
        x0, y0, _, _ = self.geometry.arena
        xs = x0 + (torch.arange(self._nx) + 0.5) * self.h
        ys = y0 + (torch.arange(self._ny) + 0.5) * self.h
        centres = torch.stack(torch.meshgrid(xs, ys, indexing="ij"), -1).reshape(-1, 2)
        table = torch.cat([self.direction(centres), self.nominal_speed(centres).unsqueeze(-1)], -1)
        return table.reshape(self._nx, self._ny, 3)

    # ------------------------------------------------------------------------------ acting
    def direction(self, p: torch.Tensor) -> torch.Tensor:
        """Unit descent direction of the cost-to-goal field at ``p`` ``[..., 2]``."""
        h = self.h
        ex = torch.tensor([h, 0.0])
        ey = torch.tensor([0.0, h])
        grad = torch.stack(
            [self.cost_to_go(p + ex) - self.cost_to_go(p - ex), self.cost_to_go(p + ey) - self.cost_to_go(p - ey)], -1
        )
        norm = torch.linalg.vector_norm(grad, dim=-1, keepdim=True)
        gx0, gy0, gx1, gy1 = self.geometry.goal
        to_goal = torch.tensor([(gx0 + gx1) / 2, (gy0 + gy1) / 2]) - p
        fallback = to_goal / torch.linalg.vector_norm(to_goal, dim=-1, keepdim=True).clamp_min(1e-6)
        return torch.where(norm > 1e-8, -grad / norm.clamp_min(1e-8), fallback)

    def nominal_speed(self, p: torch.Tensor) -> torch.Tensor:
        """Commanded speed (cm/step): a smooth, increasing function of the clearance at ``p``."""
        c = self.geometry.clearance(p, self._rects).clamp_min(0.0)
        return self.speed_min + (self.speed_max - self.speed_min) * (1 - torch.exp(-c / self.clearance_scale))

    def __call__(self, p: torch.Tensor, generator: torch.Generator | None = None) -> torch.Tensor:
        """Noisy velocity command at positions ``p`` ``[..., 2]`` (direction and speed tabulated at
        plan time on the grid and interpolated bilinearly: smooth, and cheap enough for every step)."""
        p = p.float().cpu()
        table = self._bilinear(self._table, p)
        direction = table[..., :2] / torch.linalg.vector_norm(table[..., :2], dim=-1, keepdim=True).clamp_min(1e-6)
        speed = table[..., 2:]
        mean = speed * direction
        std = self.noise_floor + self.noise_gain * speed
        noise = torch.randn(mean.shape, generator=generator) * std
        return (mean + noise).clamp(-self.geometry.max_speed, self.geometry.max_speed)

    # ------------------------------------------------------------------------------ supervising
    def wants_control(self, p: torch.Tensor, learner_action: torch.Tensor, in_control: torch.Tensor) -> torch.Tensor:
        """HG-DAgger's expert judgement ``[..., 1]`` bool at positions ``p`` ``[..., 2]``.

        It takes over when the learner's command, held for a few steps, would graze a wall or leave
        the arena, or points far from (or is much slower than) its own command, or wherever the
        clearance is below ``narrow_clearance`` (it does the narrow parts itself); once in control
        it hands back only in open space (clearance above ``release_clearance``) when the
        learner's command agrees with its own and the roll-out is safe.
        """
        rule = self.takeover
        p, a = p.float().cpu(), learner_action.float().cpu()
        in_control = in_control.cpu().reshape(*p.shape[:-1], 1).bool()
        table = self._bilinear(self._table, p)
        direction = table[..., :2] / torch.linalg.vector_norm(table[..., :2], dim=-1, keepdim=True).clamp_min(1e-6)
        nominal = table[..., 2]
        danger = torch.zeros(p.shape[:-1], dtype=torch.bool)
        for k in range(1, int(rule.lookahead_steps) + 1):
            q = p + k * a
            danger |= (self.geometry.clearance(q, self._rects) < rule.margin) | ~self.geometry.in_arena(q)
        speed = torch.linalg.vector_norm(a, dim=-1)
        cos = (a * direction).sum(-1) / speed.clamp_min(1e-8)
        deviates = (cos < math.cos(math.radians(rule.max_angle_deg))) | (speed < rule.min_speed_ratio * nominal)
        agrees = (cos >= math.cos(math.radians(rule.release_angle_deg))) & ~deviates
        clearance = self.geometry.clearance(p, self._rects)
        open_space = clearance > rule.release_clearance
        take = (danger | deviates | (clearance < rule.narrow_clearance)).unsqueeze(-1)
        keep = ~(open_space & agrees & ~danger).unsqueeze(-1)
        return torch.where(in_control, keep, take)
