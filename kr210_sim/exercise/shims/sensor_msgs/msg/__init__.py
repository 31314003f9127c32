"""sensor_msgs.msg: its messages (:mod:`kr210_sim.exercise.messages`)."""

from kr210_sim.exercise.messages import (
    JointState,
)

__all__ = [
    "JointState",
]
