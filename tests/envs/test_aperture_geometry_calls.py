"""The aperture env's geometry with fewer torch calls gives the very values of the formulas it replaced (kept
below as they were at commit 5818c2d): every collision, goal and arena test of a run stays what it was."""

import torch

from dpiil_rl.envs.aperture_geometry import ApertureGeometry, segment_rect_distance
from tests.conftest import ROOT, load_config, plain


def _points(n: int, seed: int) -> torch.Tensor:
    """Random points over the arena and beyond, points on walls, goal and arena edges, and repeats (still)."""
    g = torch.Generator().manual_seed(seed)
    p = torch.rand(n, 2, generator=g) * 24 - 2
    edges = torch.tensor([0.0, 20.0, 13.0, 17.0, 1.0, 5.0, 9.5, 10.5, 3.5, 6.5, 0.7, 0.1])
    p[: n // 4] = edges[torch.randint(0, len(edges), (n // 4, 2), generator=g)]
    p[n // 4 : n // 2, 0] = edges[torch.randint(0, len(edges), (n // 2 - n // 4,), generator=g)]
    return p


def test_the_collision_goal_and_arena_tests_are_the_formulas_they_replaced():
    geo = ApertureGeometry.from_mapping(
        {
            k: v
            for k, v in plain(load_config(ROOT / "configs/env/aperture.yaml")).items()
            if k not in ("_target_", "name", "expert")
        }
    )
    rects = geo.rectangles()
    for seed in range(5):
        p0 = _points(4000, seed)
        step = torch.rand(4000, 2, generator=torch.Generator().manual_seed(100 + seed)) * 2 - 1
        step[::7] = 0.0  # no motion
        step[1::7, 0] = 0.0  # motion along one axis only
        p1 = p0 + step
        d_new = segment_rect_distance(p0.unsqueeze(-2), p1.unsqueeze(-2), rects)
        d_old = _old_segment_rect_distance(p0.unsqueeze(-2), p1.unsqueeze(-2), rects)
        assert torch.equal(d_new, d_old)
        assert torch.equal(geo.segment_collides(p0, p1, rects), (d_old < geo.agent_radius).any(-1))
        for box, test in ((geo.arena, geo.in_arena), (geo.goal, geo.in_goal)):
            x0, y0, x1, y1 = box
            for p in (p1, p1.double()):
                old = (p[..., 0] >= x0) & (p[..., 0] <= x1) & (p[..., 1] >= y0) & (p[..., 1] <= y1)
                assert torch.equal(test(p), old)


def test_a_box_edge_that_float32_cannot_hold_is_compared_as_before():
    p = torch.tensor([[0.7, 0.7], [0.69999, 0.7], [0.3, 0.3]])
    from dpiil_rl.envs.aperture_geometry import _in_box

    for box in ((0.7, 0.3, 5.0, 5.0), (0.1, 0.1, 0.7, 0.7)):
        x0, y0, x1, y1 = box
        for q in (p, p.double()):
            old = (q[..., 0] >= x0) & (q[..., 0] <= x1) & (q[..., 1] >= y0) & (q[..., 1] <= y1)
            assert torch.equal(_in_box(q, box), old)


# ------------------------------------------------------------------ the formulas as they were (commit 5818c2d)
def _old_point_rect_distance(p: torch.Tensor, rects: torch.Tensor) -> torch.Tensor:
    """Euclidean distance from points ``[..., 2]`` to rectangles ``[W, 4]`` (broadcast; 0 inside)."""
    dx = torch.clamp(torch.maximum(rects[..., 0] - p[..., 0], p[..., 0] - rects[..., 2]), min=0.0)
    dy = torch.clamp(torch.maximum(rects[..., 1] - p[..., 1], p[..., 1] - rects[..., 3]), min=0.0)
    return torch.sqrt(dx * dx + dy * dy)


def _old_point_segment_distance(c: torch.Tensor, p0: torch.Tensor, p1: torch.Tensor) -> torch.Tensor:
    d = p1 - p0
    dd = (d * d).sum(-1)
    t = ((c - p0) * d).sum(-1) / torch.where(dd > 0, dd, torch.ones_like(dd))
    t = torch.where(dd > 0, t.clamp(0.0, 1.0), torch.zeros_like(t))
    closest = p0 + t.unsqueeze(-1) * d
    return torch.linalg.vector_norm(closest - c, dim=-1)


def _old_segment_intersects_rect(p0: torch.Tensor, p1: torch.Tensor, rects: torch.Tensor) -> torch.Tensor:
    """Liang-Barsky slab test of segments ``p0 -> p1`` against rectangles (broadcast)."""
    d = p1 - p0
    t_lo = torch.zeros(torch.broadcast_shapes(p0.shape[:-1], rects.shape[:-1]), dtype=p0.dtype)
    t_hi = torch.ones_like(t_lo)
    for axis in (0, 1):
        lo, hi = rects[..., axis], rects[..., axis + 2]
        o, v = p0[..., axis], d[..., axis]
        still = v.abs() < 1e-12
        safe_v = torch.where(still, torch.ones_like(v), v)
        t1, t2 = (lo - o) / safe_v, (hi - o) / safe_v
        enter, leave = torch.minimum(t1, t2), torch.maximum(t1, t2)
        inside = (o >= lo) & (o <= hi)
        enter = torch.where(still, torch.where(inside, -torch.inf, torch.inf), enter)
        leave = torch.where(still, torch.where(inside, torch.inf, -torch.inf), leave)
        t_lo, t_hi = torch.maximum(t_lo, enter), torch.minimum(t_hi, leave)
    return t_lo <= t_hi


def _old_segment_rect_distance(p0: torch.Tensor, p1: torch.Tensor, rects: torch.Tensor) -> torch.Tensor:
    """Minimum distance between segments and rectangles (broadcast); exact in 2D.

    For two disjoint convex sets in the plane, the minimum distance is attained at a vertex of one
    of them, so it is the smallest of: segment end points to the rectangle, rectangle corners to
    the segment. It is 0 when the segment crosses the rectangle.
    """
    ends = torch.stack(torch.broadcast_tensors(p0, p1), 0)  # [2, ..., 1, 2]
    d_ends = _old_point_rect_distance(ends, rects).amin(0)
    corners = rects[..., [[0, 1], [2, 1], [0, 3], [2, 3]]]  # [W, 4, 2]
    d_corners = _old_point_segment_distance(corners, p0.unsqueeze(-2), p1.unsqueeze(-2)).amin(-1)
    dist = torch.minimum(d_ends, d_corners)
    return torch.where(_old_segment_intersects_rect(p0, p1, rects), torch.zeros_like(dist), dist)
