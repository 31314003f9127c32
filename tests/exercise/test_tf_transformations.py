"""tf.transformations as ROS shipped it, against tf's documented behaviour: the values of its
docstring examples, (x, y, z, w) quaternions, 3x3 rotations where tf read them, gimbal lock."""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy

from kr210_sim.exercise import tf_transformations as tft
from kr210_sim.robot.quaternions import quaternion_from_rotation, rotation_from_quaternion


def test_the_documented_examples() -> None:
    """The values tf's docstrings give."""
    assert np.allclose(tft.quaternion_about_axis(0.123, (1, 0, 0)), [0.06146124, 0, 0, 0.99810947])
    assert np.allclose(tft.euler_from_quaternion([0.06146124, 0, 0, 0.99810947]), [0.123, 0, 0])
    assert np.allclose(
        tft.quaternion_from_euler(1, 2, 3, "ryxz"), [0.310622, -0.718287, 0.444435, 0.435953]
    )
    R = tft.rotation_matrix(0.123, (1, 2, 3))
    assert np.allclose(tft.quaternion_from_matrix(R), [0.0164262, 0.0328524, 0.0492786, 0.9981095])
    assert np.allclose(
        tft.quaternion_matrix([0.06146124, 0, 0, 0.99810947]), tft.rotation_matrix(0.123, (1, 0, 0))
    )
    q = tft.quaternion_multiply([1, -2, 3, 4], [-5, 6, 7, 8])
    assert np.allclose(q, [-44, -14, 48, 28])
    assert np.allclose(np.sum(tft.euler_matrix(1, 2, 3, "syxz")[0]), -1.34786452)
    assert np.allclose(np.sum(tft.euler_matrix(1, 2, 3, (0, 1, 0, 1))[0]), -0.383436184)
    R = tft.rotation_matrix(math.pi / 2, [0, 0, 1], [1, 0, 0])
    assert np.allclose(R @ [0, 0, 0, 1], [1.0, -1.0, 0.0, 1.0])
    assert np.allclose(tft.quaternion_conjugate([1, 2, 3, 4]), [-1, -2, -3, 4])
    q = np.array([0.2, -0.4, 0.1, 0.8])
    assert np.allclose(tft.quaternion_multiply(q, tft.quaternion_inverse(q)), [0, 0, 0, 1])


def test_every_axis_convention_round_trips() -> None:
    """All 24 conventions: matrix -> angles -> matrix, and the quaternion of the angles is the
    matrix's rotation (tf's own examples: ``euler_matrix(*euler_from_matrix(R0, axes), axes)``)."""
    assert len(tft._AXES2TUPLE) == 24
    rng = np.random.default_rng(3)
    for axes in tft._AXES2TUPLE:
        for a in rng.uniform(-math.pi, math.pi, (20, 3)):
            R0 = tft.euler_matrix(*a, axes=axes)
            R1 = tft.euler_matrix(*tft.euler_from_matrix(R0, axes), axes=axes)
            assert np.allclose(R0, R1, atol=1e-12), axes
            assert np.allclose(tft.quaternion_matrix(tft.quaternion_from_euler(*a, axes=axes)), R0)
    with pytest.raises(KeyError):
        tft.euler_matrix(1, 2, 3, "sxyy")
    with pytest.raises(KeyError):
        tft.euler_matrix(1, 2, 3, (0, 1, 1, 2))


def test_quaternions_are_x_y_z_w() -> None:
    """The scalar part last: a quarter turn about z is (0, 0, sin 45, cos 45), as ROS's
    messages carry it, and tf agrees with our (x, y, z, w) conversions on random rotations."""
    q = tft.quaternion_from_euler(0, 0, math.pi / 2)
    assert np.allclose(q, [0, 0, math.sqrt(0.5), math.sqrt(0.5)])
    rng = np.random.default_rng(7)
    for _ in range(200):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        assert np.allclose(tft.quaternion_matrix(q)[:3, :3], rotation_from_quaternion(q))
        M = np.eye(4)
        M[:3, :3] = rotation_from_quaternion(q)
        ours = np.array(quaternion_from_rotation(M[:3, :3]))
        theirs = tft.quaternion_from_matrix(M)
        assert np.allclose(ours, theirs) or np.allclose(ours, -theirs)


def test_euler_reads_a_3x3_and_quaternion_from_matrix_needs_a_4x4() -> None:
    """tf's euler_from_matrix took the top-left 3x3 of anything (a 3x3 rotation too, a sympy
    Matrix too); its quaternion_from_matrix read M[3, 3], so a 3x3 failed there, as under ROS."""
    R = tft.euler_matrix(0.3, -0.2, 1.1)
    assert np.allclose(tft.euler_from_matrix(R[:3, :3]), (0.3, -0.2, 1.1))
    assert np.allclose(tft.euler_from_matrix(sympy.Matrix(R[:3, :3])), (0.3, -0.2, 1.1))
    with pytest.raises(IndexError):
        tft.quaternion_from_matrix(R[:3, :3])


def test_gimbal_lock_and_degenerate_quaternions() -> None:
    """At pitch 90 deg the third angle is 0 and the first carries the rest (tf's rule); a
    zero quaternion is the identity."""
    R = tft.euler_matrix(0.4, math.pi / 2, 0.3)
    roll, pitch, yaw = tft.euler_from_matrix(R)
    assert yaw == 0.0 and pitch == pytest.approx(math.pi / 2)
    assert np.allclose(tft.euler_matrix(roll, pitch, yaw), R)
    assert np.array_equal(tft.quaternion_matrix([0, 0, 0, 0]), np.eye(4))


def test_slerp_translation_and_composition() -> None:
    q0 = tft.random_quaternion([0.1, 0.2, 0.3])
    q1 = tft.random_quaternion([0.7, 0.5, 0.9])
    assert np.allclose(tft.quaternion_slerp(q0, q1, 0.0), q0)
    assert np.allclose(tft.quaternion_slerp(q0, q1, 1.0, 1), q1)
    q = tft.quaternion_slerp(q0, q1, 0.5)
    angle = math.acos(np.dot(q0, q))
    d = np.dot(q0, q1)
    assert np.isclose(2.0, math.acos(d) / angle) or np.isclose(2.0, math.acos(-d) / angle)
    v = np.array([0.3, -0.2, 0.5])
    assert np.allclose(tft.translation_from_matrix(tft.translation_matrix(v)), v)
    T0 = tft.compose_matrix((1, 2, 3), (0.1, 0.2, 0.3), (0.4, 0.5, 0.6), (1, 2, 3), (0, 0, 0, 1))
    assert np.allclose(T0, tft.compose_matrix(*tft.decompose_matrix(T0)))
    M = tft.concatenate_matrices(tft.translation_matrix(v), tft.rotation_matrix(0.5, (0, 1, 0)))
    assert tft.is_same_transform(M, M @ np.eye(4)) and tft.is_same_transform(
        tft.inverse_matrix(M) @ M, np.eye(4)
    )
    angle, direction, point = tft.rotation_from_matrix(
        tft.rotation_matrix(0.4, (1, 2, 3), (1, 1, 1))
    )
    assert angle == pytest.approx(0.4) and np.allclose(
        direction, np.array([1, 2, 3]) / math.sqrt(14)
    )
    assert np.allclose(tft.rotation_matrix(angle, direction, point) @ [1, 1, 1, 1], [1, 1, 1, 1])


def test_a_function_tf_had_that_is_not_here_is_one_line() -> None:
    with pytest.raises(AttributeError, match=r"tf.transformations.superimposition_matrix is not"):
        tft.superimposition_matrix  # noqa: B018
