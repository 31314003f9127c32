"""visualization_msgs.msg: its messages (:mod:`kr210_sim.exercise.messages`)."""

from kr210_sim.exercise.messages import (
    Marker,
    MarkerArray,
)

__all__ = [
    "Marker",
    "MarkerArray",
]
