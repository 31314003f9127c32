"""Where the arm holds the wrist camera for a second look at a target: at the pick's standoff
(:func:`~kr210_sim.plan.poses.pick_poses`), the gripper level and pointing at the target, a
little higher, so the camera (on gripper_link, looking forward and down) has the target and its
neighbours in the middle of its image."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from kr210_sim.cell.spec import MotionConfig
from kr210_sim.plan.poses import pick_poses, untwisted_nearest
from kr210_sim.robot.description import RobotDescription
from kr210_sim.robot.kinematics import Kinematics

FloatArray = npt.NDArray[np.float64]

#: How far above the standoff the gripper looks from [m].
LOOK_RISE = 0.1


def wrist_look_pose(
    robot: RobotDescription,
    target_position: npt.ArrayLike,
    radius: float = 0.05,
    motion: MotionConfig | None = None,
) -> FloatArray:
    """gripper_link's pose (4 x 4, base frame) for a wrist look at a target centred at
    ``target_position`` [m] of ``radius`` [m]: the pick's standoff raised by
    :data:`LOOK_RISE`."""
    T = pick_poses(robot, motion or MotionConfig(), target_position, radius)[0].copy()
    T[2, 3] += LOOK_RISE
    return T


def wrist_look_q(
    kinematics: Kinematics,
    robot: RobotDescription,
    target_position: npt.ArrayLike,
    q_ref: npt.ArrayLike,
    radius: float = 0.05,
) -> FloatArray:
    """The arm's joints [rad] for :func:`wrist_look_pose`, the untwisted solution nearest
    ``q_ref`` [rad].

    Raises:
        UnreachablePoseError: When the pose has no solution within the limits.
    """
    T = wrist_look_pose(robot, target_position, radius)
    return untwisted_nearest(kinematics, T, np.asarray(q_ref, dtype=np.float64))
