"""``mocap_to_robot``: the rigid transform from the capture system's frame to the robot base frame.

Motive streams Y-up by default while the UR5e base is Z-up, and the capture volume's origin is wherever
the ground plane was calibrated. A pose ``(p, q)`` of the hand in the mocap frame becomes
``(R p + t, q_R * q)`` in the robot frame: the position is rotated and shifted, the orientation is
rotated on the left (the hand's own axes stay the hand's). ``R`` must be a proper rotation; a typo in a
calibration (a flipped axis, a scale) is an error, not a silently different robot motion.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(frozen=True, eq=False)
class RigidTransform:
    rotation: np.ndarray  # (3, 3) proper rotation, mocap axes -> robot axes
    translation: np.ndarray  # (3,) m, the mocap origin in the robot frame

    def __post_init__(self) -> None:
        rotation = np.array(self.rotation, dtype=np.float64)
        translation = np.array(self.translation, dtype=np.float64)
        if rotation.shape != (3, 3) or translation.shape != (3,):
            raise ValueError(
                f"mocap_to_robot: rotation has shape {rotation.shape} and translation {translation.shape}; "
                "expected a 3x3 rotation and a 3-vector"
            )
        if not (np.all(np.isfinite(rotation)) and np.all(np.isfinite(translation))):
            raise ValueError(
                f"mocap_to_robot has non-finite entries: rotation {rotation.tolist()}, "
                f"translation {translation.tolist()}"
            )
        if not np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-6) or np.linalg.det(rotation) < 0:
            raise ValueError(
                f"mocap_to_robot.rotation = {rotation.tolist()} is not a proper rotation: expected an "
                "orthonormal matrix with determinant +1 (rows are unit, perpendicular; no mirror, no scale)"
            )
        rotation.setflags(write=False)
        translation.setflags(write=False)
        object.__setattr__(self, "rotation", rotation)
        object.__setattr__(self, "translation", translation)
        object.__setattr__(self, "_q", matrix_to_quaternion(rotation))

    @classmethod
    def identity(cls) -> RigidTransform:
        return cls(np.eye(3), np.zeros(3))

    @classmethod
    def from_config(cls, value: RigidTransform | Mapping[str, Any] | None) -> RigidTransform:
        """From ``{rotation: 3x3 rows, translation: [x, y, z]}`` (either key may be left out), None = identity."""
        if value is None:
            return cls.identity()
        if isinstance(value, RigidTransform):
            return value
        if not isinstance(value, Mapping):
            raise TypeError(
                f"mocap_to_robot = {value!r}: expected a mapping with 'rotation' (3x3) and 'translation' (3)"
            )
        unknown = set(value) - {"rotation", "translation"}
        if unknown:
            raise ValueError(
                f"mocap_to_robot has unknown key(s) {sorted(unknown)}; expected 'rotation' and 'translation'"
            )
        rotation = value.get("rotation")
        translation = value.get("translation")
        return cls(
            np.eye(3) if rotation is None else _floats(rotation),
            np.zeros(3) if translation is None else _floats(translation),
        )

    def apply(self, position: np.ndarray, quaternion: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(R p + t, q_R * q)`` for positions (..., 3) and w, x, y, z quaternions (..., 4)."""
        return position @ self.rotation.T + self.translation, quaternion_multiply(self._q, quaternion)  # type: ignore[attr-defined]


def quaternion_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product ``a * b`` of w, x, y, z quaternions (..., 4) (rotate by ``b``, then by ``a``)."""
    aw, ax, ay, az = np.moveaxis(np.asarray(a, dtype=np.float64), -1, 0)
    bw, bx, by, bz = np.moveaxis(np.asarray(b, dtype=np.float64), -1, 0)
    return np.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        axis=-1,
    )


def matrix_to_quaternion(rotation: np.ndarray) -> np.ndarray:
    """The unit w, x, y, z quaternion of a proper rotation matrix (Shepperd's method: divide by the largest term)."""
    m = rotation
    trace = m[0, 0] + m[1, 1] + m[2, 2]
    candidates = [trace, m[0, 0], m[1, 1], m[2, 2]]
    k = int(np.argmax(candidates))
    if k == 0:
        s = 2.0 * np.sqrt(1.0 + trace)
        q = [0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
    elif k == 1:
        s = 2.0 * np.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = [(m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s]
    elif k == 2:
        s = 2.0 * np.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = [(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s]
    else:
        s = 2.0 * np.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = [(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s]
    quaternion = np.array(q)
    return quaternion / np.linalg.norm(quaternion)


def _floats(value: Any) -> Any:
    """Nested sequences (lists, OmegaConf ListConfig) to nested lists of floats."""
    if isinstance(value, (int, float, np.number)) and not isinstance(value, bool):
        return float(value)
    if isinstance(value, (str, bytes, bool)) or not hasattr(value, "__iter__"):
        raise ValueError(f"mocap_to_robot: {value!r} is not a number")
    return [_floats(v) for v in value]
