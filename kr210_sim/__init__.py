"""kr210_sim: a MuJoCo simulation of a KUKA KR210 pick-and-place cell.

Importing the package picks an offscreen OpenGL backend when none is chosen: with no
``DISPLAY`` set, ``MUJOCO_GL`` defaults to ``egl`` (Mesa's software EGL works on headless
machines). This must happen before :mod:`mujoco` is imported anywhere.
"""

from __future__ import annotations

import os
import sys

#: True when kr210_sim chose MUJOCO_GL after mujoco was already imported (too late to count).
GL_CHOSEN_LATE = False
if "MUJOCO_GL" not in os.environ and not os.environ.get("DISPLAY"):
    os.environ["MUJOCO_GL"] = "egl"
    os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
    GL_CHOSEN_LATE = "mujoco" in sys.modules

__version__ = "0.1.0"

from kr210_sim.errors import (  # noqa: E402 (after the MUJOCO_GL choice)
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
