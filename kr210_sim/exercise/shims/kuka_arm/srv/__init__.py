"""kuka_arm.srv: the exercise's ``CalculateIK`` service (:mod:`kr210_sim.exercise.messages`)."""

from kr210_sim.exercise.messages import CalculateIK, CalculateIKRequest, CalculateIKResponse

__all__ = ["CalculateIK", "CalculateIKRequest", "CalculateIKResponse"]
