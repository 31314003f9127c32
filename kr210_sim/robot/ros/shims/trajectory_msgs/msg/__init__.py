"""trajectory_msgs.msg: its messages (:mod:`kr210_sim.robot.ros.messages`)."""

from kr210_sim.robot.ros.messages import (
    JointTrajectory,
    JointTrajectoryPoint,
)

__all__ = [
    "JointTrajectory",
    "JointTrajectoryPoint",
]
