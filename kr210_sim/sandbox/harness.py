"""What of kr210_sim a jail holds: the harness that talks to the grader, and nothing that solves
the problem.

A user's process in a jail (:mod:`kr210_sim.sandbox.jail`) must import
:mod:`kr210_sim.sandbox.ik_child` and what it needs to load the user's code and answer over the
pipe (:data:`MODULES`: the wire, the loader, the exercise's ROS shims for a server), and nothing
of the grader's own solution: not the closed-form kinematics (:mod:`kr210_sim.robot.kinematics`,
``ik_scalar``, the compiled ``_ik_native``), not the robot's description, the planner, the cells
or the scenes. The jail binds these files alone, one by one, over an empty folder at the
package's path (:func:`files`): what is not bound is not there to be read, whatever the user's
code does. The packages' ``__init__`` files are not bound (theirs import the rest of the
package), so in a jail ``kr210_sim``, ``kr210_sim.robot``, ... are namespace packages.

That alone would let an attempt pass unseen (a ``try: from kr210_sim.robot.kinematics import
nearest`` with a fallback of its own). :class:`Guard` is put first on :data:`sys.meta_path` in the
user's process before the user's code is imported: an import of a kr210_sim module that is not
in the harness raises :class:`ModuleNotFoundError` saying so, and is kept
(:attr:`Guard.blocked`); the process reports the names with its answers, and the grader names the
attempt in the verdict. The guard is a report, not the wall: code that removes it finds no file
to import either.

This module runs in the user's process too: it imports nothing but the standard library.
"""

from __future__ import annotations

import importlib.abc
import importlib.machinery
from collections.abc import Sequence
from pathlib import Path
from types import ModuleType

#: The package's name.
PACKAGE = "kr210_sim"
#: The module files of kr210_sim a jail holds, relative to the package folder.
MODULES = (
    "errors.py",
    "util/processes.py",
    "robot/quaternions.py",
    "sandbox/harness.py",
    "sandbox/ik_child.py",
    "sandbox/ik_wire.py",
    "sandbox/perception_child.py",
    "sandbox/user_ik.py",
    "sandbox/user_perception.py",
)
#: The folders of kr210_sim a jail holds whole (the exercise's ROS form and its shims).
FOLDERS = ("exercise",)
#: Most names of blocked imports kept per process.
MAX_BLOCKED = 20


def files(package: Path) -> list[Path]:
    """The harness's files and folders under ``package`` (kr210_sim's folder) that exist."""
    found = [package / m for m in MODULES] + [package / f for f in FOLDERS]
    return [p for p in found if p.exists()]


def module_name(relative: str) -> str:
    """The module a harness path names (``sandbox/ik_child.py``: ``kr210_sim.sandbox.ik_child``)."""
    parts = relative.removesuffix(".py").split("/")
    return ".".join((PACKAGE, *parts))


def allowed(fullname: str) -> bool:
    """Whether ``fullname`` (a module of kr210_sim) is in the harness: one of :data:`MODULES`, a
    module in one of :data:`FOLDERS`, or a package on the way to them."""
    if fullname.partition(".")[0] != PACKAGE:
        return True
    modules = [module_name(m) for m in MODULES]
    folders = [module_name(f) for f in FOLDERS]
    if fullname in modules or any(fullname == f or fullname.startswith(f + ".") for f in folders):
        return True
    return any(m.startswith(fullname + ".") for m in (*modules, *folders))


class Guard(importlib.abc.MetaPathFinder):
    """Refuses the imports of kr210_sim modules outside the harness, and keeps their names.

    Attributes:
        blocked: The names refused, in order, each once (at most :data:`MAX_BLOCKED`).
        sent: How many of :attr:`blocked` were reported already (:meth:`news`).
    """

    def __init__(self) -> None:
        self.blocked: list[str] = []
        self.sent = 0

    def find_spec(
        self,
        fullname: str,
        path: Sequence[str] | None,
        target: ModuleType | None = None,
    ) -> importlib.machinery.ModuleSpec | None:
        """None for what is allowed (the next finder looks); a refusal, kept, for the rest."""
        if allowed(fullname):
            return None
        if fullname not in self.blocked and len(self.blocked) < MAX_BLOCKED:
            self.blocked.append(fullname)
        raise ModuleNotFoundError(
            f"No module named {fullname!r}: the grader's own code is not in the jail (only its "
            "harness is)",
            name=fullname,
        )

    def news(self) -> list[str]:
        """The names refused since the last call."""
        new = self.blocked[self.sent :]
        self.sent = len(self.blocked)
        return new


def install() -> Guard:
    """Put a :class:`Guard` first on :data:`sys.meta_path` and return it."""
    import sys

    guard = Guard()
    sys.meta_path.insert(0, guard)
    return guard
