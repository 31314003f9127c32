"""The KR210 itself: its description read from the URDF, closed-form kinematics, meshes, and a
user's IK."""

from __future__ import annotations

from kr210_sim.robot.description import RobotDescription, load_robot
from kr210_sim.robot.ik_guard import CheckedIk, assess
from kr210_sim.robot.kinematics import Kinematics
from kr210_sim.robot.user_ik import UserIk, load_ik

__all__ = [
    "CheckedIk",
    "Kinematics",
    "RobotDescription",
    "UserIk",
    "assess",
    "load_ik",
    "load_robot",
]
