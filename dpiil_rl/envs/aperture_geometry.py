"""Geometry of the aperture-passing task: validated config, wall rectangles, exact circle collisions.

All lengths are in centimetres and all times in control steps, as in the paper (section V-A).
Walls are axis-aligned rectangles; the agent is a disc of radius ``agent_radius``. A step moves
the disc's centre along a straight segment, and the step collides iff the minimum distance from
that segment to any wall rectangle is below the radius (exact: no tunnelling through a thin wall).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from typing import Any, Mapping

import torch

Rect = tuple[float, float, float, float]  # x_min, y_min, x_max, y_max


def _rect(values: Any, name: str) -> Rect:
    if values is None or len(values) != 4:
        raise ValueError(f"{name} = {values!r}: expected [x_min, y_min, x_max, y_max] (4 numbers, cm)")
    x0, y0, x1, y1 = (float(v) for v in values)
    if not (x1 > x0 and y1 > y0):
        raise ValueError(f"{name} = {list(values)!r}: expected x_max > x_min and y_max > y_min")
    return (x0, y0, x1, y1)


@dataclass(frozen=True)
class Barrier:
    """A straight wall of given thickness, optionally pierced by one aperture."""

    name: str
    orientation: str  # "horizontal" (wall along x at y = position) or "vertical"
    position: float  # centre line of the wall (y for horizontal, x for vertical), cm
    thickness: float  # cm
    span: tuple[float, float]  # extent along the wall, cm
    aperture_center: float | None = None  # centre of the gap along the wall, cm
    aperture_width: float | None = None  # gap width, cm

    def rectangles(self) -> list[Rect]:
        lo, hi = self.span
        pieces = [(lo, hi)]
        if self.aperture_width is not None:
            c, w = float(self.aperture_center), float(self.aperture_width)  # type: ignore[arg-type]
            pieces = [(lo, c - w / 2), (c + w / 2, hi)]
        half = self.thickness / 2
        rects: list[Rect] = []
        for a, b in pieces:
            if b - a <= 0:
                continue
            if self.orientation == "horizontal":
                rects.append((a, self.position - half, b, self.position + half))
            else:
                rects.append((self.position - half, a, self.position + half, b))
        return rects


@dataclass(frozen=True)
class ApertureGeometry:
    """Validated geometry of the task; build it with :meth:`from_mapping` from the env config."""

    arena: Rect
    goal: Rect
    start_center: tuple[float, float]
    start_noise: float
    agent_radius: float
    max_speed: float
    max_steps: int
    barriers: tuple[Barrier, ...] = field(default_factory=tuple)

    @classmethod
    def from_mapping(cls, cfg: Mapping[str, Any]) -> "ApertureGeometry":
        radius = float(cfg["agent_radius"])
        if radius <= 0:
            raise ValueError(f"env.agent_radius = {radius}: expected a positive radius in cm")
        max_speed = float(cfg["max_speed"])
        if max_speed <= 0:
            raise ValueError(f"env.max_speed = {max_speed}: expected a positive speed bound in cm/step")
        max_steps = int(cfg["max_steps"])
        if max_steps <= 0:
            raise ValueError(f"env.max_steps = {max_steps}: expected a positive number of steps")
        arena = _rect(cfg["arena"], "env.arena")
        goal = _rect(cfg["goal"], "env.goal")
        start = cfg["start"]
        center = tuple(float(v) for v in start["center"])
        if len(center) != 2:
            raise ValueError(f"env.start.center = {center!r}: expected [x, y]")
        noise = float(start["noise"])
        if noise < 0:
            raise ValueError(f"env.start.noise = {noise}: expected a half-width >= 0 cm")
        barriers = []
        for name, b in (cfg.get("barriers") or {}).items():
            barriers.append(_barrier(name, b, radius))
        geo = cls(
            arena=arena,
            goal=goal,
            start_center=(center[0], center[1]),
            start_noise=noise,
            agent_radius=radius,
            max_speed=max_speed,
            max_steps=max_steps,
            barriers=tuple(barriers),
        )
        geo._check_layout()
        return geo

    def _check_layout(self) -> None:
        x0, y0, x1, y1 = self.arena
        for label, (px, py) in {
            "env.start (lowest corner)": (
                self.start_center[0] - self.start_noise,
                self.start_center[1] - self.start_noise,
            ),
            "env.start (highest corner)": (
                self.start_center[0] + self.start_noise,
                self.start_center[1] + self.start_noise,
            ),
        }.items():
            if not (x0 < px < x1 and y0 < py < y1):
                raise ValueError(f"{label} = ({px}, {py}): expected inside env.arena = {list(self.arena)}")
        start = torch.tensor([self.start_center])
        if bool((self.point_distance(start) < self.agent_radius + self.start_noise * 2**0.5).any()):
            raise ValueError(
                f"env.start = {self.start_center} ± {self.start_noise}: a start position can touch a wall; "
                "expected the whole start square to be clear of walls by the agent radius"
            )

    # ----------------------------------------------------------------------------------- walls
    def rectangles(self) -> torch.Tensor:
        """All wall rectangles as a ``[W, 4]`` float tensor (x_min, y_min, x_max, y_max)."""
        rects = [r for b in self.barriers for r in b.rectangles()]
        return torch.tensor(rects, dtype=torch.float32).reshape(-1, 4)

    def apertures(self) -> list[tuple[str, float]]:
        """(barrier name, width) for every aperture, in config order."""
        return [(b.name, float(b.aperture_width)) for b in self.barriers if b.aperture_width is not None]

    def point_distance(self, p: torch.Tensor, rects: torch.Tensor | None = None) -> torch.Tensor:
        """Distance from points ``[..., 2]`` to the nearest wall rectangle (0 inside a wall)."""
        rects = self.rectangles() if rects is None else rects
        if rects.numel() == 0:
            return torch.full(p.shape[:-1], float("inf"), dtype=p.dtype)
        return point_rect_distance(p.unsqueeze(-2), rects).amin(-1)

    def clearance(self, p: torch.Tensor, rects: torch.Tensor | None = None) -> torch.Tensor:
        """Free space around the agent's disc: distance to the nearest wall or arena edge minus the radius."""
        x0, y0, x1, y1 = self.arena
        edge = torch.stack([p[..., 0] - x0, x1 - p[..., 0], p[..., 1] - y0, y1 - p[..., 1]], -1).amin(-1)
        return torch.minimum(self.point_distance(p, rects), edge) - self.agent_radius

    def segment_collides(self, p0: torch.Tensor, p1: torch.Tensor, rects: torch.Tensor) -> torch.Tensor:
        """Whether moving the disc from ``p0`` to ``p1`` (``[N, 2]``) touches any wall (``[N]`` bool)."""
        if rects.numel() == 0:
            return torch.zeros(p0.shape[:-1], dtype=torch.bool)
        d = segment_rect_distance(p0.unsqueeze(-2), p1.unsqueeze(-2), rects)
        return (d < self.agent_radius).any(-1)

    def in_arena(self, p: torch.Tensor) -> torch.Tensor:
        return _in_box(p, tuple(self.arena))

    def in_goal(self, p: torch.Tensor) -> torch.Tensor:
        return _in_box(p, tuple(self.goal))


def _barrier(name: str, b: Mapping[str, Any], radius: float) -> Barrier:
    where = f"env.barriers.{name}"
    orientation = str(b["orientation"])
    if orientation not in ("horizontal", "vertical"):
        raise ValueError(f"{where}.orientation = {orientation!r}: expected 'horizontal' or 'vertical'")
    thickness = float(b["thickness"])
    if thickness <= 0:
        raise ValueError(f"{where}.thickness = {thickness}: expected a positive thickness in cm")
    span = tuple(float(v) for v in b["span"])
    if len(span) != 2 or span[1] <= span[0]:
        raise ValueError(f"{where}.span = {list(b['span'])!r}: expected [start, end] with end > start (cm)")
    width = b.get("aperture_width")
    center = b.get("aperture_center")
    if width is not None:
        width = float(width)
        if width <= 0:
            raise ValueError(f"{where}.aperture_width = {width}: expected a positive width in cm")
        if width <= 2 * radius:
            raise ValueError(
                f"{where}.aperture_width = {width}: narrower than the agent (diameter {2 * radius} cm); "
                f"expected a width > 2 * env.agent_radius"
            )
        if center is None:
            raise ValueError(f"{where}.aperture_center = None: expected a position (cm) when aperture_width is set")
        center = float(center)
        if not (span[0] + width / 2 <= center <= span[1] - width / 2):
            raise ValueError(
                f"{where}.aperture_center = {center}: expected the aperture to lie within span {list(span)}"
            )
    return Barrier(
        name=name,
        orientation=orientation,
        position=float(b["position"]),
        thickness=thickness,
        span=(span[0], span[1]),
        aperture_center=center,
        aperture_width=width,
    )


# ----------------------------------------------------------------------------------- distances
# Every env step runs these on a few points, so their cost is the number of torch calls: constants are made once,
# and each float operation is the one it always was (a test compares them with the formulas they replaced).
_CORNERS = torch.tensor([[0, 1], [2, 1], [0, 3], [2, 3]])  # the corners of (x_min, y_min, x_max, y_max)


@functools.lru_cache(maxsize=64)
def _box_bounds(box: tuple[float, ...], dtype: torch.dtype, device: torch.device) -> tuple[torch.Tensor, torch.Tensor]:
    """``(x_min, y_min)`` and ``(x_max, y_max)`` of ``box`` as tensors of ``dtype`` (what comparing a tensor of that
    dtype with the Python numbers casts them to)."""
    x0, y0, x1, y1 = box
    return torch.tensor([x0, y0], dtype=dtype, device=device), torch.tensor([x1, y1], dtype=dtype, device=device)


def _in_box(p: torch.Tensor, box: tuple[float, ...]) -> torch.Tensor:
    """Whether points ``[..., 2]`` lie in the closed rectangle ``box`` = (x_min, y_min, x_max, y_max)."""
    lo, hi = _box_bounds(box, p.dtype, p.device)
    return ((p >= lo) & (p <= hi)).all(-1)


def point_rect_distance(p: torch.Tensor, rects: torch.Tensor) -> torch.Tensor:
    """Euclidean distance from points ``[..., 2]`` to rectangles ``[W, 4]`` (broadcast; 0 inside)."""
    dx = torch.clamp(torch.maximum(rects[..., 0] - p[..., 0], p[..., 0] - rects[..., 2]), min=0.0)
    dy = torch.clamp(torch.maximum(rects[..., 1] - p[..., 1], p[..., 1] - rects[..., 3]), min=0.0)
    return torch.sqrt(dx * dx + dy * dy)


def point_segment_distance(c: torch.Tensor, p0: torch.Tensor, p1: torch.Tensor) -> torch.Tensor:
    d = p1 - p0
    dd = (d * d).sum(-1)
    t = ((c - p0) * d).sum(-1) / torch.where(dd > 0, dd, 1.0)
    t = torch.where(dd > 0, t.clamp(0.0, 1.0), 0.0)
    closest = p0 + t.unsqueeze(-1) * d
    return torch.linalg.vector_norm(closest - c, dim=-1)


@functools.lru_cache(maxsize=64)
def _broadcast_shape(a: torch.Size, b: torch.Size) -> torch.Size:
    """``torch.broadcast_shapes`` remembered: every env step asks it for the same two shapes."""
    return torch.broadcast_shapes(a, b)


def segment_intersects_rect(p0: torch.Tensor, p1: torch.Tensor, rects: torch.Tensor) -> torch.Tensor:
    """Liang-Barsky slab test of segments ``p0 -> p1`` against rectangles (broadcast)."""
    d = p1 - p0
    t_lo = torch.zeros(_broadcast_shape(p0.shape[:-1], rects.shape[:-1]), dtype=p0.dtype)
    t_hi = torch.ones_like(t_lo)
    for axis in (0, 1):
        lo, hi = rects[..., axis], rects[..., axis + 2]
        o, v = p0[..., axis], d[..., axis]
        still = v.abs() < 1e-12
        safe_v = torch.where(still, 1.0, v)
        t1, t2 = (lo - o) / safe_v, (hi - o) / safe_v
        enter, leave = torch.minimum(t1, t2), torch.maximum(t1, t2)
        inside = (o >= lo) & (o <= hi)
        enter = torch.where(still, torch.where(inside, -torch.inf, torch.inf), enter)
        leave = torch.where(still, torch.where(inside, torch.inf, -torch.inf), leave)
        t_lo, t_hi = torch.maximum(t_lo, enter), torch.minimum(t_hi, leave)
    return t_lo <= t_hi


def segment_rect_distance(p0: torch.Tensor, p1: torch.Tensor, rects: torch.Tensor) -> torch.Tensor:
    """Minimum distance between segments and rectangles (broadcast); exact in 2D.

    For two disjoint convex sets in the plane, the minimum distance is attained at a vertex of one
    of them, so it is the smallest of: segment end points to the rectangle, rectangle corners to
    the segment. It is 0 when the segment crosses the rectangle.
    """
    ends = torch.stack(torch.broadcast_tensors(p0, p1), 0)  # [2, ..., 1, 2]
    d_ends = point_rect_distance(ends, rects).amin(0)
    corners = rects[..., _CORNERS]  # [W, 4, 2]
    d_corners = point_segment_distance(corners, p0.unsqueeze(-2), p1.unsqueeze(-2)).amin(-1)
    dist = torch.minimum(d_ends, d_corners)
    return torch.where(segment_intersects_rect(p0, p1, rects), 0.0, dist)
