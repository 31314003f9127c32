"""trajectory_msgs.msg: its messages (:mod:`kr210_sim.exercise.messages`)."""

from kr210_sim.exercise.messages import (
    JointTrajectory,
    JointTrajectoryPoint,
)

__all__ = [
    "JointTrajectory",
    "JointTrajectoryPoint",
]
