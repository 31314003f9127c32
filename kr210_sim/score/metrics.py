"""Figures computed from a cycle's per-tick samples (shared by the runner's results and plots)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from kr210_sim.robot.kinematics import Kinematics

FloatArray = npt.NDArray[np.float64]


def gripper_tracking_error_mm(
    kin: Kinematics, q: npt.ArrayLike, q_des: npt.ArrayLike
) -> FloatArray:
    """The joint tracking error seen at the gripper, per sample [mm].

    Distance between gripper_link's origin at the measured joints ``q`` and at the commanded
    joints ``q_des`` (both (N, 6) [rad]), by ``kin``'s forward kinematics. It restates the joint
    tracking error in Cartesian terms; it says nothing about IK accuracy (the plan's poses are
    exact).
    """
    q_arr = np.asarray(q, dtype=np.float64).reshape(-1, 6)
    q_des_arr = np.asarray(q_des, dtype=np.float64).reshape(-1, 6)
    if not len(q_arr):
        return np.zeros(0)
    actual = kin.forward(q_arr)[:, :3, 3]
    planned = kin.forward(q_des_arr)[:, :3, 3]
    return np.linalg.norm(actual - planned, axis=1) * 1000.0
