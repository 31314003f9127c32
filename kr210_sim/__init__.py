"""kr210_sim: a MuJoCo simulation of a KUKA KR210 pick-and-place cell.

Importing the package picks an offscreen OpenGL backend when none is chosen: with no ``DISPLAY``
set, ``MUJOCO_GL`` defaults to ``egl`` (Mesa's software EGL works on headless machines). This
must happen before :mod:`mujoco` is imported anywhere, so the package imports :mod:`mujoco`
first thing, once (:mod:`kr210_sim.util.gl`): when ``MUJOCO_GL`` names no backend mujoco knows,
or a backend whose library is missing, mujoco's import raises. The physics needs no OpenGL, so
mujoco is then imported with its OpenGL backend disabled and the reason is kept in
:data:`kr210_sim.util.gl.GL_IMPORT_ERROR`; rendering (:func:`kr210_sim.media.render.make_renderer`)
refuses with it in one line. MuJoCo's warnings are routed to :mod:`logging` (logger ``mujoco``)
instead of a ``MUJOCO_LOG.TXT`` file in the current folder.

The Python API (:mod:`kr210_sim.api`) is reached from the top level without importing it up
front, so ``import kr210_sim`` stays light: ``kr210_sim.run(...)``, ``kr210_sim.evaluate(...)``,
``kr210_sim.ik_check(...)``, ``kr210_sim.grade(...)`` and the report types load it on first use
(the evaluation's machinery is the module :mod:`kr210_sim.eval.evaluate`). The Gymnasium
environment is registered by ``import kr210_sim.envs``.

The rooms, in the order data flows through them (each imports only rooms before it): errors,
util, robot, cell and exercise, sandbox, perception, plan and score, sim, media and sensors, eval,
grading, view and envs, jobs, results, api, commands, cli.
"""

from __future__ import annotations

from typing import Any

import os as _os  # isort: skip
import sys as _sys  # isort: skip

# ``python -m kr210_sim`` puts its working folder first on ``sys.path``: a ``ruckig/`` or
# ``numpy.py`` there (a class folder graded from inside) would be imported by the grader,
# outside any jail. The package is found by now; the folder goes before anything else is
# imported (a module SPEC there is still found: kr210_sim.sandbox.user_ik.find_module).
if _sys.argv[:1] == ["-m"] and _sys.path and _sys.path[0] in ("", _os.getcwd()):
    del _sys.path[0]

from kr210_sim.util import gl as _gl  # noqa: F401  # isort: skip (first: MUJOCO_GL, mujoco)
from kr210_sim import _moved
from kr210_sim.errors import (
    ConfigError,
    Kr210SimError,
    PlanningError,
    RenderError,
    SceneError,
    UnreachablePoseError,
)
from kr210_sim.util.versions import package_version

_moved.install()  # the module paths that moved in 0.2.0 keep working until 0.3.0, with a warning

#: The package version (from the installed metadata: pyproject.toml is the one place it is set).
__version__ = package_version()

#: Names the package loads from :mod:`kr210_sim.api` on first use.
_API = frozenset(
    {
        "run",
        "evaluate",
        "ik_check",
        "grade",
        "Report",
        "RunReport",
        "EvalReport",
        "GradeReport",
        "IkCheckReport",
        "RunInterrupted",
    }
)


def __getattr__(name: str) -> Any:
    """The API's functions and types, imported on first use (PEP 562)."""
    if name in _API:
        from kr210_sim import api

        return getattr(api, name)
    raise AttributeError(f"module 'kr210_sim' has no attribute {name!r}")


#: The public API: what ``from kr210_sim import *`` gives and what the package serves at the top
#: level (the errors, the version, and the API's names of :data:`_API`, loaded on first use).
__all__ = [
    "ConfigError",
    "EvalReport",
    "GradeReport",
    "IkCheckReport",
    "Kr210SimError",
    "PlanningError",
    "RenderError",
    "Report",
    "RunInterrupted",
    "RunReport",
    "SceneError",
    "UnreachablePoseError",
    "__version__",
    "evaluate",
    "grade",
    "ik_check",
    "run",
]
