"""The gripper poses of a plan and the IK solutions a pick tries for them."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kr210_sim.cell.spec import MotionConfig
from kr210_sim.plan.poses import (
    UNTWISTED,
    branch_solutions,
    grasp_depth,
    gripper_pose,
    pick_poses,
    release_pose,
    untwisted_nearest,
)
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


def test_the_pick_and_release_poses_hold_the_target_where_asked() -> None:
    """The held target's centre sits ``grasp_depth`` along the gripper's x and ``grasp_dz``
    below it: at the grasp it is the target's centre, lifted by ``lift`` at the lift, and at
    release above the drop spot at ``drop_height``; every pose points its x the same way."""
    robot, m = load_robot(), MotionConfig()
    r = 0.05
    centre = np.array([0.0, 0.0, -m.grasp_dz])
    centre[0] = grasp_depth(robot, r)

    def held(T: np.ndarray) -> np.ndarray:
        return T[:3, :3] @ centre + T[:3, 3]

    target = np.array([2.1, 0.7, 1.2])
    lifted = np.array([0.0, 0.0, m.lift])
    for yaw in (None, 0.4):
        standoff, grasp, lift, back = pick_poses(robot, m, target, r, yaw)
        heading = math.atan2(target[1], target[0]) if yaw is None else yaw
        u = np.array([math.cos(heading), math.sin(heading), 0.0])
        np.testing.assert_allclose(held(grasp), target, atol=1e-12)
        np.testing.assert_allclose(held(lift), target + lifted, atol=1e-12)
        np.testing.assert_allclose(held(standoff), target - m.standoff * u, atol=1e-12)
        np.testing.assert_allclose(held(back), held(standoff) + lifted, atol=1e-12)
        for T in (standoff, grasp, lift, back):
            np.testing.assert_allclose(T[:3, 0], u, atol=1e-12)
    drop = np.array([-0.4, 1.9])
    T = release_pose(robot, m, drop, r)
    np.testing.assert_allclose(held(T)[:2], drop, atol=1e-12)
    assert held(T)[2] == pytest.approx(m.drop_height - m.grasp_dz)
