"""kr210_sim: a MuJoCo simulation of a KUKA KR210 pick-and-place cell.

Importing the package picks an offscreen OpenGL backend when none is chosen: with no
``DISPLAY`` set, ``MUJOCO_GL`` defaults to ``egl`` (Mesa's software EGL works on headless
machines). This must happen before :mod:`mujoco` is imported anywhere, so the package imports
:mod:`mujoco` here, once: when ``MUJOCO_GL`` names no backend mujoco knows, or a backend whose
library is missing, mujoco's import raises. The physics needs no OpenGL, so mujoco is then
imported with its OpenGL backend disabled and the reason is kept in :data:`GL_IMPORT_ERROR`;
rendering (:func:`kr210_sim.media.render.make_renderer`) refuses with it in one line. MuJoCo's
warnings are routed to :mod:`logging` (logger ``mujoco``) instead of a ``MUJOCO_LOG.TXT`` file in
the current folder.

The Python API (:mod:`kr210_sim.api`) is reached from the top level without importing it up
front, so ``import kr210_sim`` stays light: ``kr210_sim.run(...)``, ``kr210_sim.evaluate(...)``,
``kr210_sim.ik_check(...)`` and the report types load it on first use (the evaluation's
machinery is the module :mod:`kr210_sim.eval.evaluate`). The Gymnasium environment is registered by
``import kr210_sim.envs``.
"""

from __future__ import annotations

import logging
import os
import sys
from typing import Any

#: True when kr210_sim chose MUJOCO_GL after mujoco was already imported (too late to count).
GL_CHOSEN_LATE = False
if "MUJOCO_GL" not in os.environ and not os.environ.get("DISPLAY"):
    os.environ["MUJOCO_GL"] = "egl"
    os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
    GL_CHOSEN_LATE = "mujoco" in sys.modules

#: Why mujoco's OpenGL backend could not be imported (``"<type>: <message>"``), or None.
GL_IMPORT_ERROR: str | None = None

#: Modules that a failed import of mujoco's OpenGL backend may leave half-initialised.
_GL_MODULES = ("mujoco", "OpenGL", "glfw")


def _import_mujoco() -> str | None:
    """Import mujoco; when only its OpenGL backend fails, import it without one.

    Returns:
        The backend's import error as one line, or None when mujoco imported as it was.
    """
    try:
        import mujoco
    except Exception as exc:  # mujoco raises RuntimeError, PyOpenGL AttributeError, OSError ...
        first = exc
    else:
        return None
    gl = os.environ.get("MUJOCO_GL")
    # Forget the Python modules the failed import left behind (compiled extension modules are
    # kept: they do not depend on MUJOCO_GL and cannot be initialised twice).
    for name, module in list(sys.modules.items()):
        source = str(getattr(module, "__file__", None))
        if name.split(".")[0] in _GL_MODULES and source.endswith(".py"):
            del sys.modules[name]
    os.environ["MUJOCO_GL"] = "disable"
    try:
        import mujoco  # noqa: F401
    except Exception:
        raise first from None  # not the OpenGL backend's fault: the original error stands
    finally:
        if gl is None:
            del os.environ["MUJOCO_GL"]
        else:
            os.environ["MUJOCO_GL"] = gl  # so child processes make the same choice
    return " ".join(f"{type(first).__name__}: {first}".split())


def _log_mujoco_warning(message: str) -> None:
    """MuJoCo's warnings (an unstable simulation, a full contact buffer, ...) go to logging;
    MuJoCo's own handler prints them to stdout and appends them to ``MUJOCO_LOG.TXT`` in the
    current folder."""
    logging.getLogger("mujoco").warning("%s", message)


if "mujoco" not in sys.modules:  # else whoever imported mujoco first keeps their handlers
    GL_IMPORT_ERROR = _import_mujoco()
    import mujoco

    mujoco.set_mju_user_warning(_log_mujoco_warning)

from kr210_sim.util.versions import package_version  # noqa: E402

#: The package version (from the installed metadata: pyproject.toml is the one place it is set).
__version__ = package_version()

from kr210_sim.errors import (  # noqa: E402 (after the MUJOCO_GL choice)
    ConfigError,
    Kr210SimError,
    PlanningError,
    RenderError,
    SceneError,
    UnreachablePoseError,
)

#: Names the package loads from :mod:`kr210_sim.api` on first use.
_API = frozenset(
    {
        "run",
        "evaluate",
        "ik_check",
        "Report",
        "RunReport",
        "EvalReport",
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


__all__ = [
    "ConfigError",
    "Kr210SimError",
    "PlanningError",
    "RenderError",
    "SceneError",
    "UnreachablePoseError",
    "__version__",
    "evaluate",
    "ik_check",
    "run",
]
