"""The import paths that moved in 0.2.0, kept working for one release with a DeprecationWarning.

0.2.0 gave the jail, the exercise's own form and the grader rooms of their own
(``kr210_sim.sandbox``, ``kr210_sim.exercise``, ``kr210_sim.grading``). An import by an old path
(``import kr210_sim.robot.jail``, ``from kr210_sim.eval.grade import grade``) still works: it
warns once, with the new path, and gives the very module the new path gives (one module object,
not a copy). Names the old packages exported (``from kr210_sim.robot import UserIk``) are served
by :func:`moved_attribute`. The old paths go in 0.3.0.

This module imports nothing of the package by an import statement: the old names are strings
that :mod:`importlib` resolves on use, so the table adds no arrow between the rooms.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import importlib.util
import sys
import warnings
from types import ModuleType

#: Old module path prefix -> new one. Longest prefixes first where one contains another.
MOVED_MODULES: dict[str, str] = {
    "kr210_sim.robot.ros": "kr210_sim.exercise",
    **{
        f"kr210_sim.robot.{m}": f"kr210_sim.sandbox.{m}"
        for m in (
            "bwrap",
            "cgroups",
            "confine",
            "ik_child",
            "ik_guard",
            "ik_sandbox",
            "ik_wire",
            "jail",
            "procfs",
            "seccomp",
            "user_ik",
        )
    },
    **{
        f"kr210_sim.eval.{m}": f"kr210_sim.grading.{m}"
        for m in (
            "budget",
            "diagnose",
            "finding",
            "grade",
            "ik_debug",
            "ikcheck",
            "leaderboard",
            "record",
            "roster",
            "student",
        )
    },
}

#: (old package, name) -> the module that now defines the name.
MOVED_NAMES: dict[tuple[str, str], str] = {
    ("kr210_sim.robot", "CheckedIk"): "kr210_sim.sandbox.ik_guard",
    ("kr210_sim.robot", "assess"): "kr210_sim.sandbox.ik_guard",
    ("kr210_sim.robot", "UserIk"): "kr210_sim.sandbox.user_ik",
    ("kr210_sim.robot", "load_ik"): "kr210_sim.sandbox.user_ik",
    ("kr210_sim.eval", "GradeSettings"): "kr210_sim.grading.grade",
    ("kr210_sim.eval", "find_students"): "kr210_sim.grading.grade",
    ("kr210_sim.eval", "run_check"): "kr210_sim.grading.ikcheck",
}

REMOVED_IN = "0.3.0"


def new_name(old: str) -> str | None:
    """The module path that replaced ``old``, or None where ``old`` did not move."""
    for prefix, target in MOVED_MODULES.items():
        if old == prefix or old.startswith(prefix + "."):
            return target + old[len(prefix) :]
    return None


def _warn(old: str, new: str, stacklevel: int) -> None:
    warnings.warn(
        f"{old} moved to {new} in 0.2.0; the old path goes in {REMOVED_IN}",
        DeprecationWarning,
        stacklevel=stacklevel,
    )


def moved_attribute(package: str, name: str) -> object:
    """A name an old package exported, from its new home, with a DeprecationWarning.

    For a package's module-level ``__getattr__`` (PEP 562).

    Raises:
        AttributeError: Where ``name`` never lived in ``package``.
    """
    home = MOVED_NAMES.get((package, name))
    if home is None:
        submodule = new_name(f"{package}.{name}")
        if submodule is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        _warn(f"{package}.{name}", submodule, 3)
        return importlib.import_module(submodule)
    _warn(f"{package}.{name}", f"{home}.{name}", 3)
    return getattr(importlib.import_module(home), name)


class _Alias(importlib.abc.Loader):
    """Loads an old module path as the module of its new path."""

    def __init__(self, target: str) -> None:
        self.target = target

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        # _warn, this frame, then the importer's line: warnings skips importlib's own frames.
        _warn(spec.name, self.target, 3)
        return importlib.import_module(self.target)

    def exec_module(self, module: ModuleType) -> None:
        """Nothing to run: the new module was executed by its own import."""


class _Finder(importlib.abc.MetaPathFinder):
    """Finds the old module paths (first on ``sys.meta_path``)."""

    def find_spec(
        self, fullname: str, path: object = None, target: object = None
    ) -> importlib.machinery.ModuleSpec | None:
        new = new_name(fullname)
        if new is None:
            return None
        return importlib.util.spec_from_loader(fullname, _Alias(new))


def install() -> None:
    """Put the old paths' finder first on ``sys.meta_path`` (once)."""
    if not any(isinstance(f, _Finder) for f in sys.meta_path):
        sys.meta_path.insert(0, _Finder())
