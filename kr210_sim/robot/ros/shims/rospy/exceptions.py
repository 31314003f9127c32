"""rospy.exceptions: :mod:`kr210_sim.robot.ros.node`'s."""

from kr210_sim.robot.ros.node import (
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
