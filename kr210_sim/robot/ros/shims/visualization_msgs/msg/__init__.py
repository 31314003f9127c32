"""visualization_msgs.msg: its messages (:mod:`kr210_sim.robot.ros.messages`)."""

from kr210_sim.robot.ros.messages import (
    Marker,
    MarkerArray,
)

__all__ = [
    "Marker",
    "MarkerArray",
]
