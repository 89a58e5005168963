"""The ring-threading task's fixed facts (paper section V-B): where things are and how the state reads.

Everything here is plain data (no MuJoCo import), so the scripted expert, the plots and the specs
can use it in the main process while the simulations run in worker processes. The geometry values
are those of robosuite's ``NutAssemblyRound`` arena; :class:`~dpiil_rl.envs.ring_sim.RingSim`
checks them against the loaded model and refuses to run if they disagree.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np
import torch

#: the 51-D state, in order: (robosuite observation key, size). robosuite <= 1.4's flat UR5e state.
STATE_KEYS: tuple[tuple[str, int], ...] = (
    ("robot0_joint_pos_cos", 6),
    ("robot0_joint_pos_sin", 6),
    ("robot0_joint_vel", 6),
    ("robot0_eef_pos", 3),
    ("robot0_eef_quat", 4),
    ("robot0_gripper_qpos", 6),
    ("robot0_gripper_qvel", 6),
    ("RoundNut_to_robot0_eef_pos", 3),
    ("RoundNut_to_robot0_eef_quat", 4),
    ("RoundNut_pos", 3),
    ("RoundNut_quat", 4),
)


def _slices() -> dict[str, slice]:
    out, start = {}, 0
    for key, size in STATE_KEYS:
        out[key] = slice(start, start + size)
        start += size
    return out


STATE_SLICES: dict[str, slice] = _slices()
STATE_DIM: int = sum(size for _, size in STATE_KEYS)  # 51


@dataclass(frozen=True)
class RingGeometry:
    """Positions in metres (robosuite world frame), angles in radians, times in control steps."""

    round_peg_xy: tuple[float, float] = (0.23, -0.1)  # axis of the round peg the ring is threaded on
    square_peg_xy: tuple[float, float] = (0.23, 0.1)  # the other peg: touching it is a collision
    peg_radius: float = 0.02  # round peg radius
    peg_top_z: float = 0.95  # top of both pegs
    table_z: float = 0.82  # table surface
    ring_inner_radius: float = 0.0312  # inner radius of the ring (clearance = inner - peg radius)
    ring_half_height: float = 0.01  # the ring is 2 cm thick
    handle_offset: float = 0.06  # handle centre along the ring's local x axis
    max_steps: int = 200  # horizon; not threaded by then = failure
    max_translation: float = 0.05  # metres per step at action 1 (OSC output limit)
    max_rotation: float = 0.5  # radians per step at action 1
    observation_low: tuple[float, ...] = ()  # per-dimension bounds of the 51-D state (specs, normalisation)
    observation_high: tuple[float, ...] = ()

    @property
    def clearance(self) -> float:
        """Radial gap between the ring's inner edge and the peg when centred (m)."""
        return self.ring_inner_radius - self.peg_radius

    @classmethod
    def from_mapping(cls, spec: Mapping[str, Any]) -> "RingGeometry":
        spec = dict(spec)
        bounds = spec.pop("observation_bounds", None)
        known = set(cls.__dataclass_fields__)
        unknown = sorted(set(spec) - known)
        if unknown:
            raise ValueError(f"ring geometry keys {unknown}: unknown (expected some of {sorted(known)})")
        low, high = observation_bounds(bounds or {})
        fields: dict[str, Any] = {k: tuple(v) if isinstance(v, list) else v for k, v in spec.items()}
        geometry = cls(
            **fields,
            observation_low=tuple(low),
            observation_high=tuple(high),
        )
        if geometry.clearance <= 0:
            raise ValueError(
                f"ring_inner_radius = {geometry.ring_inner_radius} <= peg_radius = {geometry.peg_radius}: "
                "expected a ring wider than the peg"
            )
        if int(geometry.max_steps) < 1:
            raise ValueError(f"max_steps = {geometry.max_steps}: expected a positive horizon")
        return geometry


def observation_bounds(spec: Mapping[str, Any]) -> tuple[list[float], list[float]]:
    """Per-dimension ``(low, high)`` of the 51-D state from ``{robosuite key: [low, high]}``.

    Every key of :data:`STATE_KEYS` needs an entry; a pair applies to all of the key's dimensions,
    a pair of lists gives them one by one.
    """
    missing = [k for k, _ in STATE_KEYS if k not in spec]
    if spec and missing:
        raise ValueError(f"observation_bounds: no bounds for {missing} (expected [low, high] for every state key)")
    low: list[float] = []
    high: list[float] = []
    for key, size in STATE_KEYS:
        lo, hi = spec.get(key, (-1.0, 1.0)) if spec else (-1.0, 1.0)
        lo_v = list(lo) if isinstance(lo, (list, tuple)) else [float(lo)] * size
        hi_v = list(hi) if isinstance(hi, (list, tuple)) else [float(hi)] * size
        if len(lo_v) != size or len(hi_v) != size or any(a >= b for a, b in zip(lo_v, hi_v)):
            raise ValueError(f"observation_bounds[{key!r}] = {[lo, hi]}: expected low < high, {size} values each")
        low += [float(v) for v in lo_v]
        high += [float(v) for v in hi_v]
    return low, high


@dataclass
class RingState:
    """Named views of a batch of 51-D states ``[N, 51]`` (no copies)."""

    observation: torch.Tensor
    views: dict[str, torch.Tensor] = field(init=False)

    def __post_init__(self) -> None:
        self.views = {k: self.observation[..., s] for k, s in STATE_SLICES.items()}

    @property
    def eef_pos(self) -> torch.Tensor:
        return self.views["robot0_eef_pos"]

    @property
    def eef_quat(self) -> torch.Tensor:  # x, y, z, w (robosuite convention)
        return self.views["robot0_eef_quat"]

    @property
    def ring_pos(self) -> torch.Tensor:
        return self.views["RoundNut_pos"]

    @property
    def ring_quat(self) -> torch.Tensor:
        return self.views["RoundNut_quat"]

    @property
    def gripper_qpos(self) -> torch.Tensor:
        return self.views["robot0_gripper_qpos"]

    @property
    def gripper_qvel(self) -> torch.Tensor:
        return self.views["robot0_gripper_qvel"]


def quat_to_matrix(quat: torch.Tensor) -> torch.Tensor:
    """Rotation matrices ``[..., 3, 3]`` from quaternions ``[..., 4]`` in (x, y, z, w) order."""
    q = quat / quat.norm(dim=-1, keepdim=True).clamp_min(1e-9)
    x, y, z, w = q.unbind(-1)
    return torch.stack(
        [
            torch.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
            torch.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
            torch.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
        ],
        -2,
    )


def heading(rotation: torch.Tensor) -> torch.Tensor:
    """Angle in the xy plane of the local x axis of ``rotation [..., 3, 3]`` (yaw, radians)."""
    return torch.atan2(rotation[..., 1, 0], rotation[..., 0, 0])


def wrap_angle(angle: torch.Tensor, period: float = 2 * torch.pi) -> torch.Tensor:
    """Angle wrapped to ``[-period / 2, period / 2)``."""
    return torch.remainder(angle + period / 2, period) - period / 2


def tilt_correction(rotation: torch.Tensor) -> torch.Tensor:
    """World-frame rotation vector ``[..., 3]`` that turns the gripper axis (local z) to point straight down."""
    axis = rotation[..., :, 2]
    down = torch.tensor([0.0, 0.0, -1.0], dtype=axis.dtype, device=axis.device).expand_as(axis)
    cross = torch.linalg.cross(axis, down)
    sin = cross.norm(dim=-1, keepdim=True)
    cos = (axis * down).sum(-1, keepdim=True)
    angle = torch.atan2(sin, cos)
    return cross / sin.clamp_min(1e-9) * angle


# ------------------------------------------------------------------------------------- grasp and stages
#: Robotiq85 first finger joint: above this the gripper is closed (or closing) ...
GRIPPER_CLOSED_QPOS = 0.15
#: ... and below this the fingers were stopped by something (0.52 rad = shut on nothing)
GRIPPER_EMPTY_QPOS = 0.505
#: the grip point must be this close to the handle centre (anywhere along the handle) (m)
HANDLE_REACH = 0.045
#: the ring counts as lifted once its centre is this far above its resting height (m)
LIFT_MARGIN = 0.02
#: the lifted ring counts as at the peg within this horizontal distance of the peg's axis (m): the radius
#: of robosuite's own success check, so "at the peg" and not threaded means it was close but not inserted
AT_PEG_RADIUS = 0.03

#: How far an episode of the ring task got, in order; an episode's stage is the furthest one it reached.
RING_STAGES: tuple[str, ...] = ("reach", "grasped", "lifted", "at_peg", "threaded")


Offsets = tuple[Any, Any, Any]  # x, y, z of the handle centre relative to the ring centre, each [N]


def handle_offsets(state: RingState, geometry: RingGeometry) -> Offsets:
    """x, y, z of the handle's centre relative to the ring's centre (``handle_offset`` along the ring's local
    x axis), each ``[N]``. Plain arithmetic on slices: works on torch tensors and on numpy arrays alike."""
    q = state.ring_quat
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    scale = 2.0 / ((q * q).sum(-1) + 1e-12)  # of the normalised quaternion
    k = geometry.handle_offset
    return (k * (1.0 - scale * (y * y + z * z)), k * scale * (x * y + z * w), k * scale * (x * z - y * w))


def handle_position(state: RingState, geometry: RingGeometry, offsets: Offsets | None = None) -> torch.Tensor:
    """World position ``[N, 3]`` of the handle's centre (``handle_offset`` along the ring's local x axis);
    ``offsets``: :func:`handle_offsets` of this state, when the caller has them already."""
    return state.ring_pos + torch.stack(offsets if offsets is not None else handle_offsets(state, geometry), -1)


def holds_handle(state: RingState, geometry: RingGeometry, offsets: Offsets | None = None) -> Any:
    """``[N]`` bool: the fingers are closed on the handle (closed, stopped short of shut, at the handle).

    Works on a state of torch tensors (the expert) or of numpy arrays (the env's per-step stage);
    ``offsets``: :func:`handle_offsets` of this state, when the caller has them already."""
    finger = state.gripper_qpos[..., 0]
    eef, ring = state.eef_pos, state.ring_pos
    hx, hy, hz = offsets if offsets is not None else handle_offsets(state, geometry)
    dx, dy, dz = eef[..., 0] - ring[..., 0] - hx, eef[..., 1] - ring[..., 1] - hy, eef[..., 2] - ring[..., 2] - hz
    at_handle = dx * dx + dy * dy + dz * dz < HANDLE_REACH**2
    return (finger > GRIPPER_CLOSED_QPOS) & (finger < GRIPPER_EMPTY_QPOS) & at_handle


def ring_stage(observation: torch.Tensor, success: torch.Tensor, geometry: RingGeometry) -> torch.Tensor:
    """The stage (index into :data:`RING_STAGES`) of every state ``[N, 51]`` reached: ``[N]`` int64.

    ``threaded`` = robosuite's success; ``at_peg`` = the ring lifted and its centre within
    :data:`AT_PEG_RADIUS` of the round peg's axis; ``lifted`` = the ring's centre :data:`LIFT_MARGIN` above
    its rest; ``grasped`` = the fingers closed on the handle; ``reach`` = none of these. Computed in numpy
    (a few microseconds per env step, where the same torch ops on one row cost ≈ 0.6 ms).
    """
    obs = observation.detach().cpu().float().numpy()
    state = RingState(obs)  # type: ignore[arg-type]
    ring = state.ring_pos
    lifted = ring[..., 2] > geometry.table_z + geometry.ring_half_height + LIFT_MARGIN
    px, py = geometry.round_peg_xy
    at_peg = lifted & ((ring[..., 0] - px) ** 2 + (ring[..., 1] - py) ** 2 < AT_PEG_RADIUS**2)
    stage = np.where(holds_handle(state, geometry), 1, 0)
    stage = np.where(lifted, 2, stage)
    stage = np.where(at_peg, 3, stage)
    stage = np.where(np.asarray(success.detach().cpu()).reshape(stage.shape), 4, stage)
    return torch.from_numpy(stage.astype(np.int64))
