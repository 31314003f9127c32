"""Seeing the parts: from a depth camera's image to labelled object poses in the base frame.

The room is pure computation on arrays (numpy, SciPy, scikit-learn, Open3D): it imports no
MuJoCo and nothing of the simulation. What the simulated sensors render arrives here as an
:class:`~kr210_sim.perception.camera.Observation`; what leaves is labelled poses.
May import: :mod:`kr210_sim.errors`, :mod:`kr210_sim.robot` (kinematics), and itself.
"""

from __future__ import annotations

from kr210_sim.perception.camera import Intrinsics, Observation, backproject, project

__all__ = ["Intrinsics", "Observation", "backproject", "project"]
