"""rospy, as an IK server uses it: :mod:`kr210_sim.exercise.node`."""

from kr210_sim.exercise.messages import Duration, Time
from kr210_sim.exercise.node import *  # noqa: F403
from kr210_sim.exercise.node import __all__ as _node_all

__all__ = [*_node_all, "Duration", "Time"]
