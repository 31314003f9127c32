"""The gripper poses of a plan and the IK solutions a pick tries for them."""

from __future__ import annotations

import math

import numpy as np

from kr210_sim.plan.poses import UNTWISTED, branch_solutions, gripper_pose, untwisted_nearest
from kr210_sim.robot.description import load_robot
from kr210_sim.robot.kinematics import Kinematics

#: A ready pose facing away from the shelf [deg].
BEHIND = (180, 0, 0, 0, 0, 0)


def test_the_branches_tried_are_the_nearest_then_the_untwisted_others() -> None:
    kin = Kinematics(load_robot())
    T = np.eye(4)
    T[:3, 3] = (1.913, 0.0, 2.447)  # slot 8's standoff
    ref = np.radians(BEHIND)
    found = branch_solutions(kin, T, ref)
    assert np.array_equal(found[0], kin.nearest(T, ref))
    assert len(found) >= 2
    for q in found:
        assert np.allclose(kin.forward(q), T, atol=1e-9)
    for q in found[1:]:
        assert abs(q[3]) <= UNTWISTED and abs(q[5]) <= UNTWISTED
        assert not np.allclose(q, found[0])
    # the nearest keeps joint 1 facing away; another faces the slot
    assert abs(found[0][0]) > math.pi / 2 and min(abs(q[0]) for q in found[1:]) < 0.1


def test_untwisted_nearest_is_the_first_untwisted_branch() -> None:
    kin = Kinematics(load_robot())
    T = gripper_pose((0.0, 2.363, 1.6), math.pi / 2)  # the published drop pose over drop 1
    ref = np.radians((90, 0, 0, 0, 0, 170))  # the wrist rolled 170 deg
    q = untwisted_nearest(kin, T, ref)
    assert abs(q[3]) <= UNTWISTED and abs(q[5]) <= UNTWISTED
    assert np.allclose(kin.forward(q), T, atol=1e-9)
    assert any(np.array_equal(q, b) for b in branch_solutions(kin, T, ref))
