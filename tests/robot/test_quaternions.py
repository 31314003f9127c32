"""Quaternions (x, y, z, w) against rotation matrices (robot/quaternions.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kr210_sim.robot.quaternions import (
    pose_matrix,
    quaternion_from_rotation,
    rotation_from_quaternion,
)


def _axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues' formula: an independent way to the same matrices."""
    k = axis / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def test_golden_rotations() -> None:
    s = math.sqrt(0.5)
    np.testing.assert_allclose(rotation_from_quaternion((0, 0, 0, 1)), np.eye(3))
    np.testing.assert_allclose(
        rotation_from_quaternion((0, 0, s, s)), [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-15
    )  # 90 deg about z: w is last
    np.testing.assert_allclose(rotation_from_quaternion((2, 0, 0, 0)), np.diag([1, -1, -1]))


def test_round_trips_and_rodrigues_over_seeded_rotations() -> None:
    rng = np.random.default_rng(11)
    for _ in range(2000):
        axis = rng.normal(size=3)
        angle = rng.uniform(-math.pi, math.pi)
        R = _axis_angle(axis, angle)
        q = quaternion_from_rotation(R)
        assert q[3] >= 0 and math.isclose(float(np.linalg.norm(q)), 1.0, rel_tol=1e-12)
        np.testing.assert_allclose(rotation_from_quaternion(q), R, atol=1e-12)
        half = axis / np.linalg.norm(axis) * math.sin(angle / 2)
        expect = np.array([*half, math.cos(angle / 2)])
        expect *= 1 if expect[3] >= 0 else -1
        np.testing.assert_allclose(q, expect, atol=1e-12)
    for angle in (math.pi, -math.pi, math.pi - 1e-9):  # w = 0 and near it: Shepperd's branches
        for axis in np.eye(3):
            R = _axis_angle(axis, angle)
            np.testing.assert_allclose(
                rotation_from_quaternion(quaternion_from_rotation(R)), R, atol=1e-9
            )


def test_pose_matrix_and_bad_quaternions() -> None:
    T = pose_matrix((1.0, 2.0, 3.0), (0, 0, 0, 1))
    np.testing.assert_array_equal(T[:3, 3], (1.0, 2.0, 3.0))
    np.testing.assert_array_equal(T[3], (0, 0, 0, 1))
    for bad in ((0, 0, 0, 0), (math.nan, 0, 0, 1), (1, 0, 0)):
        with pytest.raises(ValueError, match="a quaternion must be four finite numbers"):
            rotation_from_quaternion(bad)
