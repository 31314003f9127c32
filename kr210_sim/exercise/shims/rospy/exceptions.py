"""rospy.exceptions: :mod:`kr210_sim.exercise.node`'s."""

from kr210_sim.exercise.node import (
    ROSException,
    ROSInitException,
    ROSInterruptException,
    ROSSerializationException,
    ServiceException,
)

__all__ = [
    "ROSException",
    "ROSInitException",
    "ROSInterruptException",
    "ROSSerializationException",
    "ServiceException",
]
