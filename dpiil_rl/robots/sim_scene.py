"""The static scene of a simulated arm task: a table, fixed objects (obstacles and the target) and what
the gripper holds, as plain data, and its MJCF built from robosuite's UR5e model.

:class:`Scene` is plain data (no MuJoCo import), so the env, the scripted expert and the plots read the
same description the simulation is built from. :func:`build_mjcf` imports robosuite when it is called.

Conventions: positions are in the robot's base frame (metres; z up, the table top at z = 0 in the
shipped tasks). Sizes are MuJoCo half-sizes: box ``[hx, hy, hz]``, cylinder and capsule
``[radius, half_length]`` (axis along z), sphere ``[radius]``, torus ``[major_radius, tube_radius]``
(axis along z, built from ``segments`` capsules). Held shapes are placed relative to the TCP, along the
base frame's axes at the tool's held orientation, and move with it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from dpiil_rl.utils.robosuite_import import quiet_robosuite

SHAPES = {"box": 3, "cylinder": 2, "capsule": 2, "sphere": 1, "torus": 2}  # shape -> number of size values
ROLES = ("obstacle", "target")
SCENE_PREFIX = "scene_"  # MJCF names of the table and the fixed objects
HELD_PREFIX = "held_"  # MJCF names of what the gripper holds
ROBOT_PREFIXES = ("robot0_", "gripper0_")
# contact bit masks: the robot side (arm, gripper, held object) only touches the environment (table, floor,
# scene objects) and vice versa, so every contact MuJoCo reports is a robot-environment contact
ROBOT_CONTYPE, ROBOT_CONAFFINITY = 1, 2
ENV_CONTYPE, ENV_CONAFFINITY = 2, 1


@dataclass(frozen=True)
class SceneShape:
    """One rigid primitive."""

    name: str
    shape: str  # one of SHAPES
    size: tuple[float, ...]  # MuJoCo half-sizes (see the module docstring)
    pos: tuple[float, float, float]  # centre (scene: base frame; held: relative to the TCP)
    role: str = "obstacle"  # scene objects: "obstacle" or "target" (both are collisions on contact)
    segments: int = 24  # torus only: number of capsules around the ring
    rgba: tuple[float, float, float, float] = (0.55, 0.55, 0.6, 1.0)

    @classmethod
    def from_mapping(cls, name: str, spec: Mapping[str, Any], where: str) -> "SceneShape":
        spec = dict(spec)
        known = set(cls.__dataclass_fields__) - {"name"}
        unknown = sorted(set(spec) - known)
        if unknown:
            raise ValueError(f"{where}.{unknown[0]}: unknown key (expected some of {sorted(known)})")
        shape = str(spec.get("shape", ""))
        if shape not in SHAPES:
            raise ValueError(f"{where}.shape = {shape!r}: expected one of {sorted(SHAPES)}")
        size = tuple(float(v) for v in spec.get("size", ()))
        if len(size) != SHAPES[shape] or any(not v > 0 for v in size):
            raise ValueError(f"{where}.size = {list(size)}: expected {SHAPES[shape]} positive half-sizes for a {shape}")
        pos = tuple(float(v) for v in spec.get("pos", ()))
        if len(pos) != 3:
            raise ValueError(f"{where}.pos = {list(pos)}: expected [x, y, z] (m)")
        role = str(spec.get("role", "obstacle"))
        if role not in ROLES:
            raise ValueError(f"{where}.role = {role!r}: expected one of {ROLES}")
        segments = int(spec.get("segments", 24))
        if shape == "torus":
            if segments < 8:
                raise ValueError(f"{where}.segments = {segments}: expected at least 8 capsules around a torus")
            if size[1] >= size[0]:
                raise ValueError(f"{where}.size = {list(size)}: expected the tube radius below the major radius")
        rgba = tuple(float(v) for v in spec.get("rgba", cls.rgba))
        return cls(name=str(name), shape=shape, size=size, pos=pos, role=role, segments=segments, rgba=rgba)  # type: ignore[arg-type]

    # ------------------------------------------------------------------------------ geometry
    @property
    def half_extents(self) -> np.ndarray:
        """Half-sizes of the axis-aligned bounding box (base axes)."""
        s = self.size
        if self.shape == "box":
            return np.array(s)
        if self.shape == "cylinder":
            return np.array([s[0], s[0], s[1]])
        if self.shape == "capsule":
            return np.array([s[0], s[0], s[1] + s[0]])
        if self.shape == "sphere":
            return np.array([s[0]] * 3)
        return np.array([s[0] + s[1], s[0] + s[1], s[1]])  # torus

    @property
    def top(self) -> float:
        return float(self.pos[2] + self.half_extents[2])

    @property
    def inner_radius(self) -> float:
        """Torus only: radius of the hole at its narrowest (the midpoint of a capsule)."""
        if self.shape != "torus":
            raise ValueError(f"scene shape {self.name!r} is a {self.shape}: only a torus has a hole")
        return float(self.size[0] * math.cos(math.pi / self.segments) - self.size[1])

    def capsules(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """Torus only: ``(from, to)`` end points of the capsules that make it, relative to its centre."""
        radius = self.size[0]
        angles = 2 * math.pi * np.arange(self.segments + 1) / self.segments
        ring = np.stack([radius * np.cos(angles), radius * np.sin(angles), np.zeros_like(angles)], -1)
        return [(ring[k], ring[k + 1]) for k in range(self.segments)]


@dataclass(frozen=True)
class Scene:
    """Table, fixed objects and held objects of a task (validated)."""

    table: SceneShape
    objects: tuple[SceneShape, ...]
    held: tuple[SceneShape, ...] = ()

    @classmethod
    def from_mapping(cls, spec: Mapping[str, Any] | "Scene", where: str = "env.scene") -> "Scene":
        if isinstance(spec, Scene):
            return spec
        spec = dict(spec)
        unknown = sorted(set(spec) - {"table", "objects", "held"})
        if unknown:
            raise ValueError(f"{where}.{unknown[0]}: unknown key (expected table, objects, held)")
        if "table" not in spec:
            raise ValueError(f"{where}.table: missing (expected a box: size and pos)")
        table = SceneShape.from_mapping(
            "table", {"shape": "box", "rgba": (0.75, 0.65, 0.5, 1.0), **dict(spec["table"])}, f"{where}.table"
        )
        if table.shape != "box":
            raise ValueError(f"{where}.table.shape = {table.shape!r}: expected a box")
        objects = tuple(
            SceneShape.from_mapping(n, s, f"{where}.objects.{n}") for n, s in (spec.get("objects") or {}).items()
        )
        targets = [o.name for o in objects if o.role == "target"]
        if len(targets) != 1:
            raise ValueError(
                f"{where}.objects: {len(targets)} objects with role 'target' ({targets}): expected exactly one"
            )
        held = tuple(SceneShape.from_mapping(n, s, f"{where}.held.{n}") for n, s in (spec.get("held") or {}).items())
        return cls(table=table, objects=objects, held=held)

    @property
    def target(self) -> SceneShape:
        return next(o for o in self.objects if o.role == "target")

    @property
    def table_top(self) -> float:
        return self.table.top

    def boxes(self) -> np.ndarray:
        """Axis-aligned bounding boxes ``[K, 6]`` (centre xyz, half-sizes xyz) of the table and every object."""
        return np.array([[*s.pos, *s.half_extents] for s in (self.table, *self.objects)], dtype=np.float64)

    def to_mapping(self) -> dict[str, Any]:
        """A plain, JSON-able description (the simulation's cache key)."""

        def one(s: SceneShape) -> dict[str, Any]:
            return {
                "shape": s.shape,
                "size": list(s.size),
                "pos": list(s.pos),
                "role": s.role,
                "segments": s.segments,
                "rgba": list(s.rgba),
            }

        return {
            "table": one(self.table),
            "objects": {o.name: one(o) for o in self.objects},
            "held": {h.name: one(h) for h in self.held},
        }


# ---------------------------------------------------------------------------------- rotations (numpy)
def quat_to_matrix(quat: Any) -> np.ndarray:
    """Rotation matrix of a quaternion ``(w, x, y, z)``."""
    w, x, y, z = np.asarray(quat, dtype=np.float64) / np.linalg.norm(quat)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def matrix_to_quat(rot: np.ndarray) -> np.ndarray:
    """Quaternion ``(w, x, y, z)`` with ``w >= 0`` of a rotation matrix."""
    m = np.asarray(rot, dtype=np.float64)
    trace = m[0, 0] + m[1, 1] + m[2, 2]
    if trace > 0:
        s = 2.0 * math.sqrt(trace + 1.0)
        q = np.array([0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s])
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = np.array([(m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s])
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = np.array([(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s])
    else:
        s = 2.0 * math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = np.array([(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s])
    q = q / np.linalg.norm(q)
    return q if q[0] >= 0 else -q


def rotation_error(target: np.ndarray, current: np.ndarray) -> np.ndarray:
    """Rotation vector (world frame) that turns ``current`` into ``target`` (both 3x3)."""
    err = target @ current.T
    vec = 0.5 * np.array([err[2, 1] - err[1, 2], err[0, 2] - err[2, 0], err[1, 0] - err[0, 1]])
    sin = float(np.linalg.norm(vec))
    cos = float(np.clip((np.trace(err) - 1.0) / 2.0, -1.0, 1.0))
    angle = math.atan2(sin, cos)
    if sin < 1e-9:
        return vec if cos > 0 else np.zeros(3)
    return vec / sin * angle


def _fmt(values: Any) -> str:
    return " ".join(f"{float(v):.9g}" for v in np.ravel(values))


# ---------------------------------------------------------------------------------- MJCF
def build_mjcf(scene: Scene, gripper: str, base_height: float, tool_rotation: np.ndarray, timestep: float) -> str:
    """MJCF of a UR5e (robosuite's model and meshes) with a rigid ``gripper`` on a table with ``scene``.

    The gripper's finger joints, tendons and actuators are removed (fingers fixed open: the tasks
    command the arm only), the robot's torque motors stay (the backend's joint servo drives them), every
    body of the robot is gravity-compensated by the servo (not here), and contact bit masks make the
    robot side touch only the environment. ``tool_rotation`` (3x3, base frame) is the held TCP orientation:
    held shapes are given along base axes at that orientation and attached to the TCP's body.
    """
    with quiet_robosuite():  # lazy: importing this module never loads robosuite
        from robosuite.models import MujocoWorldBase  # noqa: PLC0415
        from robosuite.models.arenas import EmptyArena  # noqa: PLC0415
        from robosuite.models.grippers import gripper_factory  # noqa: PLC0415
        from robosuite.models.robots import UR5e  # noqa: PLC0415
        from robosuite.utils.mjcf_utils import new_body  # noqa: PLC0415

    world = MujocoWorldBase()
    robot = UR5e(idn=0)
    hand = gripper_factory(gripper, idn=0)
    for parent in list(hand.worldbody.iter()):
        for joint in list(parent.findall("joint")):
            parent.remove(joint)
    for group in (hand.tendon, hand.actuator, hand.equality, hand.contact):
        for child in list(group):
            group.remove(child)
    robot.add_gripper(hand)
    robot.set_base_xpos(np.array([0.0, 0.0, float(base_height)]))
    arena = EmptyArena()
    world.merge(arena)
    world.merge(robot)
    root = world.root
    option = root.find("option")
    assert option is not None  # robosuite's world model has an <option>
    option.set("timestep", f"{float(timestep):.9g}")
    option.set("cone", "pyramidal")
    option.set("impratio", "1")

    for geom in root.iter("geom"):
        if geom.get("contype") == "0" and geom.get("conaffinity") == "0":
            continue  # visual only
        name = geom.get("name", "")
        robot_side = name.startswith(ROBOT_PREFIXES)
        geom.set("contype", str(ROBOT_CONTYPE if robot_side else ENV_CONTYPE))
        geom.set("conaffinity", str(ROBOT_CONAFFINITY if robot_side else ENV_CONAFFINITY))

    offset = np.array([0.0, 0.0, float(base_height)])
    worldbody = root.find("worldbody")
    assert worldbody is not None  # and a <worldbody>
    for shape in (scene.table, *scene.objects):
        body = new_body(name=f"{SCENE_PREFIX}{shape.name}", pos=offset + np.array(shape.pos))
        for geom in _geoms(shape, f"{SCENE_PREFIX}{shape.name}", np.zeros(3)):
            geom.set("contype", str(ENV_CONTYPE))
            geom.set("conaffinity", str(ENV_CONAFFINITY))
            body.append(geom)
        worldbody.append(body)

    if scene.held:
        site_name = "gripper0_grip_site"
        parent = next(
            (b for b in root.iter("body") if any(s.get("name") == site_name for s in b.findall("site"))), None
        )
        if parent is None:
            raise ValueError(
                f"robot.gripper = {gripper!r}: its model has no {site_name!r} (the TCP) to hold objects at"
            )
        site = next(s for s in parent.findall("site") if s.get("name") == site_name)
        site_pos = np.array([float(v) for v in site.get("pos", "0 0 0").split()])
        site_rot = quat_to_matrix([float(v) for v in site.get("quat", "1 0 0 0").split()])
        # held shapes are along base axes at the tool orientation: in the TCP frame they are rotated by R_tool^T
        local = site_rot @ np.asarray(tool_rotation).T
        holder = new_body(name=f"{HELD_PREFIX}object", pos=site_pos, quat=matrix_to_quat(local))
        for shape in scene.held:
            for geom in _geoms(shape, f"{HELD_PREFIX}{shape.name}", np.array(shape.pos)):
                geom.set("contype", str(ROBOT_CONTYPE))
                geom.set("conaffinity", str(ROBOT_CONAFFINITY))
                geom.set("mass", "0.001")
                holder.append(geom)
        parent.append(holder)
    return world.get_xml()


def _geoms(shape: SceneShape, name: str, centre: np.ndarray) -> list[Any]:
    """MJCF ``geom`` elements of one shape, centred at ``centre`` in its body's frame."""
    from robosuite.utils.mjcf_utils import new_geom  # noqa: PLC0415

    rgba = _fmt(shape.rgba)
    if shape.shape == "torus":
        out = []
        for k, (a, b) in enumerate(shape.capsules()):
            geom = new_geom(name=f"{name}_{k}", type="capsule", size=[shape.size[1]], group=1)
            del geom.attrib["pos"]
            geom.set("fromto", _fmt(np.concatenate([centre + a, centre + b])))
            geom.set("rgba", rgba)
            out.append(geom)
        return out
    geom = new_geom(name=name, type=shape.shape, size=list(shape.size), pos=centre, group=1)
    geom.set("rgba", rgba)
    return [geom]
