"""The versions a report records: the package (from its installed metadata), Python and the
libraries that shape the results."""

from __future__ import annotations

import platform
from importlib import metadata

import numpy as np


def package_version() -> str:
    """The installed kr210_sim's version, from its package metadata (pyproject.toml's
    ``version``, the one place it is written); ``0+unknown`` for a source tree that was never
    installed."""
    try:
        return metadata.version("kr210_sim")
    except metadata.PackageNotFoundError:
        return "0+unknown"


def versions() -> dict[str, str]:
    """Versions of the package, Python and the libraries that shape the results."""
    import mujoco
    import ruckig

    out = {
        "kr210_sim": package_version(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "mujoco": mujoco.__version__,
    }
    out["ruckig"] = getattr(ruckig, "__version__", "unknown")
    try:  # the planner around obstacles
        out["ompl"] = metadata.version("ompl")
    except metadata.PackageNotFoundError:
        out["ompl"] = "unknown"
    return out
