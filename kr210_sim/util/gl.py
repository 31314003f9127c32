"""The OpenGL backend's choice and mujoco's one import (see :mod:`kr210_sim`, which imports this
module before anything else).

With no ``DISPLAY`` set, ``MUJOCO_GL`` defaults to ``egl``. When mujoco's OpenGL backend cannot be
imported, mujoco is imported without one (the physics needs none) and the reason is kept in
:data:`GL_IMPORT_ERROR` for rendering to refuse with. MuJoCo's warnings go to :mod:`logging`.
"""

from __future__ import annotations

import logging
import os
import sys

#: True when kr210_sim chose MUJOCO_GL after mujoco was already imported (too late to count).
GL_CHOSEN_LATE = False
if not os.environ.get("MUJOCO_GL", "").strip():  # unset, or set to nothing: not a choice
    os.environ.pop("MUJOCO_GL", None)
    if not os.environ.get("DISPLAY"):
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
    from kr210_sim.util.interrupts import deferred

    # Ctrl-C is held during the import and acted on after it: raised inside mujoco's extension
    # modules it became "ImportError: initialization failed", taken for a missing OpenGL
    # library, and the interrupt was lost (the command then ran to the end).
    with deferred():
        GL_IMPORT_ERROR = _import_mujoco()
    import mujoco

    mujoco.set_mju_user_warning(_log_mujoco_warning)
