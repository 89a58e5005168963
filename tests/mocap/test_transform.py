"""mocap_to_robot: matrix -> quaternion against scipy, composition, config parsing."""

from __future__ import annotations

import numpy as np
import pytest
from omegaconf import OmegaConf
from scipy.spatial.transform import Rotation

from dpiil_rl.mocap.transform import (
    RigidTransform,
    matrix_to_quaternion,
    quaternion_multiply,
)


def to_matrix(q: np.ndarray) -> np.ndarray:
    return Rotation.from_quat([q[1], q[2], q[3], q[0]]).as_matrix()


# Rotation.random(random_state=...): scipy's seeding as it was (a legacy RandomState); scipy still takes it through
# the decorator of its move to ``rng``, which the checker does not see (hence the ignores)


def test_matrix_to_quaternion_matches_scipy_in_every_branch() -> None:
    rotations = Rotation.random(200, random_state=0)  # pyright: ignore[reportCallIssue]
    # the branches of Shepperd's method: near-identity, and half turns about x, y, z (negative trace)
    extra = Rotation.from_rotvec([[1e-3, 0, 0], [np.pi, 0, 0], [0, np.pi, 0], [0, 0, np.pi], [0, 2.9, 0.5]])
    for rotation in list(rotations) + list(extra):
        q = matrix_to_quaternion(rotation.as_matrix())
        np.testing.assert_allclose(to_matrix(q), rotation.as_matrix(), atol=1e-12)


def test_apply_matches_the_matrix_composition() -> None:
    rng = np.random.default_rng(1)
    rotation = Rotation.random(random_state=2).as_matrix()  # pyright: ignore[reportCallIssue]
    transform = RigidTransform(rotation, np.array([0.1, -0.2, 0.3]))
    positions = rng.normal(size=(5, 3))
    quaternions = Rotation.random(5, random_state=3).as_quat()[:, [3, 0, 1, 2]]  # pyright: ignore[reportCallIssue]
    moved, turned = transform.apply(positions, quaternions)
    np.testing.assert_allclose(moved, positions @ rotation.T + [0.1, -0.2, 0.3], atol=1e-12)
    for q_in, q_out in zip(quaternions, turned):
        np.testing.assert_allclose(to_matrix(q_out), rotation @ to_matrix(q_in), atol=1e-12)
    single_p, single_q = transform.apply(positions[0], quaternions[0])
    np.testing.assert_allclose(single_p, moved[0])
    np.testing.assert_allclose(single_q, turned[0])


def test_quaternion_multiply_is_hamilton() -> None:
    i, j, k = np.eye(4)[1], np.eye(4)[2], np.eye(4)[3]
    np.testing.assert_array_equal(quaternion_multiply(i, j), k)
    np.testing.assert_array_equal(quaternion_multiply(j, i), -k)


def test_from_config_reads_omegaconf_and_defaults_to_identity() -> None:
    cfg = OmegaConf.create({"rotation": [[1, 0, 0], [0, 0, -1], [0, 1, 0]], "translation": [0.5, 0, 0.1]})
    transform = RigidTransform.from_config(cfg)
    np.testing.assert_array_equal(
        transform.apply(np.array([0.0, 1.0, 0.0]), np.array([1.0, 0, 0, 0]))[0], [0.5, 0, 1.1]
    )
    identity = RigidTransform.from_config(None)
    np.testing.assert_array_equal(identity.rotation, np.eye(3))
    only_shift = RigidTransform.from_config({"translation": [1, 2, 3]})
    np.testing.assert_array_equal(only_shift.rotation, np.eye(3))
    with pytest.raises(ValueError, match="'x' is not a number"):
        RigidTransform.from_config({"translation": [1, 2, "x"]})
    with pytest.raises(TypeError, match="expected a mapping"):
        RigidTransform.from_config([[1, 0, 0]])  # type: ignore[arg-type]
