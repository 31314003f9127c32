"""A CalculateIK request and its response as rospy and genpy handled them."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from kr210_sim.exercise import answers
from kr210_sim.exercise import tf_transformations as tft
from kr210_sim.exercise.messages import CalculateIKResponse, JointTrajectoryPoint
from kr210_sim.robot.description import load_robot
from kr210_sim.robot.kinematics import Kinematics


def test_a_request_holds_each_pose_as_ros_wrote_it() -> None:
    """Position and (x, y, z, w) quaternion of gripper_link in base_link: tf turns them back
    into the very transform."""
    T = Kinematics(load_robot()).forward(np.array([0.3, 0.2, -0.4, 1.0, 0.7, -0.5]))
    (pose,) = answers.request([T]).poses
    q = [pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w]
    assert np.allclose(tft.quaternion_matrix(q)[:3, :3], T[:3, :3], atol=1e-14)
    assert (pose.position.x, pose.position.y, pose.position.z) == tuple(T[:3, 3])
    assert pose.orientation.w >= 0


def test_the_pose_list_remembers_the_pose_read_last() -> None:
    poses = answers.PoseList(range(5))
    assert poses.last == -1
    poses[2]
    assert poses.last == 2
    poses[-1]
    assert poses.last == 4
    for i, _ in enumerate(poses):
        if i == 1:
            break
    assert poses.last == 1
    poses[1:4]
    assert poses.last == 3 and len(poses) == 5


def test_what_a_handler_may_return_as_rospy_read_it() -> None:
    point = JointTrajectoryPoint(positions=[0.0] * 6)
    response = CalculateIKResponse([point])
    assert answers.points(response) == [point]
    assert answers.points({"points": [point, point]}) == [point, point]
    assert answers.points(([point],)) == [point]  # a tuple of the fields
    with pytest.raises(answers.ServiceError, match=r"returned None"):
        answers.points(None)
    with pytest.raises(answers.ServiceError, match=r"holds -1 for its points"):
        answers.points(-1)
    with pytest.raises(answers.ServiceError, match=r"a list of 2 values, not CalculateIKResponse"):
        answers.points([point, point])
    with pytest.raises(answers.ServiceError, match=r"holds a JointTrajectoryPoint for its points"):
        answers.points([point])  # one point as the one field's value
    with pytest.raises(answers.ServiceError, match=r"invalid dict"):
        answers.points({"joints": []})


def test_positions_are_read_as_genpy_read_them() -> None:
    import mpmath
    import sympy

    point = JointTrajectoryPoint(
        positions=[sympy.pi / 4, mpmath.mpf("0.5"), np.float32(0.25), 1, True, sympy.Rational(1, 8)]
    )
    assert answers.angles(point) == pytest.approx([math.pi / 4, 0.5, 0.25, 1, 1, 0.125])
    assert answers.angles(JointTrajectoryPoint(positions=np.array([1.0, 2.0]))) == [1.0, 2.0]
    assert answers.angles(JointTrajectoryPoint(positions=[complex(0.5, 0.0)])) == [0.5]
    cases = [
        (
            JointTrajectoryPoint(positions=[0, np.complex128(1 + 0.5j)]),
            "a complex number",
            "joint_2 = 1+0.5j",
        ),
        (
            JointTrajectoryPoint(positions=[sympy.Symbol("t1")]),
            "an unevaluated sympy expression",
            "free symbols t1",
        ),
        (JointTrajectoryPoint(positions=[0, 0, "up"]), "a str", "joint_3 = up is no number"),
        (JointTrajectoryPoint(positions=7), "a int", "positions must be a list"),
        (JointTrajectoryPoint(positions=[0.0] * 100), "100 positions", "six joint angles"),
        ([1, 2, 3, 4, 5, 6], "a list", "JointTrajectoryPoint objects"),
    ]
    for point, what, why in cases:
        got = answers.angles(point)
        assert type(got).__name__ == what
        with pytest.raises(TypeError, match=re.escape(why)):
            np.asarray(got, dtype=float)
