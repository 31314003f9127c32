"""The KR210 itself: its description read from the URDF, closed-form kinematics (all branches,
native and pure Python), quaternions and meshes.

May import :mod:`kr210_sim.errors` and :mod:`kr210_sim.util` only. A user's IK, the jail and the
original exercise's form moved out in 0.2.0 (:mod:`kr210_sim.sandbox`, :mod:`kr210_sim.exercise`);
``from kr210_sim.robot import UserIk`` (and ``CheckedIk``, ``assess``, ``load_ik``) still works
until 0.3.0, with a DeprecationWarning.
"""

from __future__ import annotations

from kr210_sim._moved import moved_attribute
from kr210_sim.robot.description import RobotDescription, load_robot
from kr210_sim.robot.kinematics import Kinematics

__all__ = ["Kinematics", "RobotDescription", "load_robot"]


def __getattr__(name: str) -> object:
    """The names that moved to :mod:`kr210_sim.sandbox` in 0.2.0 (PEP 562), with a warning."""
    return moved_attribute(__name__, name)
