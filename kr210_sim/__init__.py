"""kr210_sim: a MuJoCo simulation of a KUKA KR210 pick-and-place cell.

Importing the package picks an offscreen OpenGL backend when none is chosen: with no
``DISPLAY`` set, ``MUJOCO_GL`` defaults to ``egl`` (Mesa's software EGL works on headless
machines). This must happen before :mod:`mujoco` is imported anywhere.
"""

from __future__ import annotations

import os

if "MUJOCO_GL" not in os.environ and not os.environ.get("DISPLAY"):
    os.environ["MUJOCO_GL"] = "egl"
    os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

__version__ = "0.1.0"

from kr210_sim.errors import (
    ConfigError,
    Kr210SimError,
    PlanningError,
    RenderError,
    SceneError,
    UnreachablePoseError,
)

__all__ = [
    "ConfigError",
    "Kr210SimError",
    "PlanningError",
    "RenderError",
    "SceneError",
    "UnreachablePoseError",
    "__version__",
]
