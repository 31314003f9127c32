"""Planning a cycle: gripper poses to joint waypoints, collision checks, timed trajectories, and
the cell check."""

from __future__ import annotations

from kr210_sim.plan.cellcheck import check_cell
from kr210_sim.plan.collide import CollisionChecker
from kr210_sim.plan.cycle import CyclePlan
from kr210_sim.plan.planner import Planner

__all__ = [
    "CollisionChecker",
    "CyclePlan",
    "Planner",
    "check_cell",
]
