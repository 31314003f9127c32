"""kuka_arm.srv: the exercise's ``CalculateIK`` service (:mod:`kr210_sim.robot.ros.messages`)."""

from kr210_sim.robot.ros.messages import CalculateIK, CalculateIKRequest, CalculateIKResponse

__all__ = ["CalculateIK", "CalculateIKRequest", "CalculateIKResponse"]
