"""Bring your own IK: load a user's inverse-kinematics function from a SPEC.

The contract (the README's "Do the exercise" section says the same)::

    def solve(T, q_ref):
        # T: (4, 4) float64 pose of gripper_link in the base frame (the frame of
        #    kinematics.forward); q_ref: (6,) current joint state [rad].
        return q  # six joint angles [rad] (any sequence of six numbers), or None if unreachable

A SPEC names the function: ``package.module:function`` (imported) or ``path/to/file.py:function``
(loaded from the file; its folder is on ``sys.path`` while it is imported). The original
exercise's form is told apart from the file (:mod:`kr210_sim.exercise.form`): a ROS service
script ``IK_server.py`` runs as ROS ran it (:mod:`kr210_sim.exercise.server`), and a repository,
its scripts folder or the script itself resolves to its SPEC ``.../IK_server.py:
handle_calculate_IK`` (:func:`~kr210_sim.exercise.form.resolve_spec`). :func:`load_ik` turns a
SPEC into a :class:`UserIk`; a bad SPEC is one :class:`~kr210_sim.errors.IkSpecError` line. A
:class:`UserIk` pickles as its SPEC, so worker processes rebuild the function from the string.
Every answer is judged before anything moves: :mod:`kr210_sim.sandbox.ik_guard`.
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.machinery
import importlib.util
import os
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import numpy.typing as npt

from kr210_sim.errors import ConfigError, IkSpecError, one_line
from kr210_sim.exercise.files import sha256_regular
from kr210_sim.exercise.form import is_ros_form, resolve_spec

FloatArray = npt.NDArray[np.float64]


# --------------------------------------------------------------------------- loading
@dataclass(frozen=True, slots=True)
class UserIk:
    """A user's IK function and the SPEC it was loaded from.

    Pickles as its SPEC (the function is re-imported on unpickling), so it can be sent to worker
    processes.

    Attributes:
        spec: The SPEC string (``module:function`` or ``file.py:function``).
        function: The callable ``solve(T, q_ref)``.
        batch: ``batch(poses) -> answers`` for an IK that takes many poses in one call and
            ignores ``q_ref`` (a ROS-form server: one request of many poses, as MoveIt sent
            them), one answer (or exception) per pose; None for ours.
        notes: What Python 2 semantics changed in the user's code since the last call (one
            line each; a ROS-form server's :class:`~kr210_sim.exercise.py2.Notes`), or None.
    """

    spec: str
    function: Callable[..., Any] = field(repr=False, compare=False)
    batch: Callable[[Sequence[FloatArray]], list[Any]] | None = field(
        default=None, repr=False, compare=False
    )
    notes: Callable[[], list[str]] | None = field(default=None, repr=False, compare=False)

    def __reduce__(self) -> tuple[Any, ...]:
        return (load_ik, (self.spec,))

    @property
    def source(self) -> Path | None:
        """The user's file, for a ``file.py:function`` SPEC (None for a module SPEC)."""
        return spec_file(self.spec)


def spec_file(spec: str) -> Path | None:
    """The file a ``file.py:function`` SPEC names (None for a module SPEC; a repository or
    scripts folder is resolved first, :func:`~kr210_sim.exercise.form.resolve_spec`)."""
    where = resolve_spec(spec).rpartition(":")[0]
    return Path(where) if _is_path(where) else None


@dataclass(frozen=True, slots=True)
class SpecFiles:
    """Where a SPEC's code lives, as a process started elsewhere (another working folder, a
    jail) must be told.

    Attributes:
        readable: The user's own files and folders the code is read from: a file SPEC's file
            alone (as ``grade`` gives a student handed in as one file: never the folder it lies
            in, a class folder), a ROS-form script's folder, its package's ``src`` and message
            definitions, a module SPEC's file or package folder when it lies outside the
            interpreter's environment (none when installed). A jail shows of them only what
            :func:`~kr210_sim.sandbox.jail_files.user_files` allows: no link is followed.
        search: Folders that must come first on ``sys.path`` for a module SPEC to import as it
            does here (the folder a module outside the environment was found in).
    """

    readable: tuple[Path, ...]
    search: tuple[Path, ...]


def _environment_roots() -> tuple[Path, ...]:
    """The interpreter's own folders: its prefixes (the standard library, site-packages)."""
    return tuple({Path(p).resolve() for p in (sys.prefix, sys.base_prefix, sys.exec_prefix)})


def find_module(name: str) -> importlib.machinery.ModuleSpec | None:
    """Where the module ``name`` would be imported from, found without running any of it: on
    ``sys.path``, else in the working folder (which is not on the path of a grading process or
    of ``python -m kr210_sim``: a class folder's ``ruckig/`` must not shadow ours). Each
    package on the way is looked up, not imported (``importlib.util.find_spec`` imports a
    dotted name's packages). None when it is not found."""
    parts = name.split(".")
    if not all(part.isidentifier() for part in parts):
        return None
    if parts[0] == __name__.split(".")[0]:
        return importlib.util.find_spec(name)  # our own package (imported already)
    for where in (None, [os.getcwd()]):
        search: list[str] | None = where
        found = None
        for depth in range(1, len(parts) + 1):
            try:
                found = importlib.machinery.PathFinder.find_spec(".".join(parts[:depth]), search)
            except (ImportError, ValueError, OSError):
                found = None
            if found is None:
                break
            search = list(found.submodule_search_locations or [])
            if depth < len(parts) and not search:
                found = None
                break
        if found is not None:
            return found
    return None


def spec_root(spec: str, root: Path) -> Path:
    """``--ik-root DIR``: the folder of the user's own files that a jail shows a file SPEC's
    code (as ``grade`` shows a folder student its folder), checked: a folder, not a link, that
    holds the SPEC's file.

    Raises:
        ConfigError: The SPEC is not a file's, or ``root`` is not a folder holding its file.
    """
    where = resolve_spec(spec).rpartition(":")[0]
    if not _is_path(where):
        raise ConfigError(f"--ik-root needs a file SPEC (path/to/file.py:function), got {spec!r}")
    if root.is_symlink() or not root.is_dir():
        raise ConfigError(f"--ik-root {str(root)!r}: not a folder (a link is not followed)")
    folder = root.resolve()
    if not Path(where).resolve().is_relative_to(folder):
        raise ConfigError(f"--ik-root {str(root)!r} does not hold the SPEC's file {where!r}")
    return folder


def spec_files(spec: str) -> SpecFiles:
    """The files a SPEC's code is read from (see :class:`SpecFiles`), found as :func:`load_ik`
    would find them in this process. A module that cannot be found gives none (loading it then
    says why). A ROS-form script's are its folder and, in a catkin package, the package's
    ``src`` folder beside it (its Python modules) and the message definitions of the catkin
    packages beside it (:func:`~kr210_sim.exercise.packages.definition_files`)."""
    where = resolve_spec(spec).rpartition(":")[0]
    if _is_path(where):
        script = Path(where).resolve()
        if not is_ros_form(Path(where)):
            return SpecFiles((script,), ())  # the file alone, as grade gives a one-file student
        from kr210_sim.exercise.packages import definition_files

        folder = script.parent
        src = folder.parent / "src"  # not resolved: a link (src -> ~instructor) is not shown
        readable = [folder, *([src] if src.is_dir() else [])]
        readable += [p for p in definition_files(Path(where)) if p not in readable]
        return SpecFiles(tuple(readable), ())
    top = where.split(".")[0]
    if not top or top == __name__.split(".")[0]:
        return SpecFiles((), ())
    found = find_module(top)
    if found is None:
        return SpecFiles((), ())
    if found.submodule_search_locations:
        places = [Path(p).resolve() for p in found.submodule_search_locations]
    elif found.origin and found.has_location:
        places = [Path(found.origin).resolve()]
    else:
        return SpecFiles((), ())  # built in or frozen
    roots = _environment_roots()
    outside = tuple(p for p in places if not any(p.is_relative_to(r) for r in roots))
    return SpecFiles(outside, tuple(dict.fromkeys(p.parent for p in outside)))


def describe_exception(exc: BaseException) -> str:
    msg = one_line(str(exc))
    return f"{type(exc).__name__}: {msg}" if msg else type(exc).__name__


def where_raised(exc: BaseException) -> str:
    """``" (file.py line N)"``: the innermost frame of ``exc``'s traceback in the user's code
    (not ours, not the interpreter's or an installed library's), as a ROS-form server's
    exceptions say it; "" when there is none (or the message ends with a place already)."""
    import re
    import traceback

    ours = str(Path(__file__).resolve().parents[1]) + os.sep
    libraries = tuple(p + os.sep for p in {sys.prefix, sys.base_prefix, sys.exec_prefix})
    found = ""
    try:
        for frame in traceback.extract_tb(exc.__traceback__):
            name = frame.filename
            if name.startswith(("<", ours, *libraries)):
                continue
            found = f" ({Path(name).name} line {frame.lineno})"
        located = re.search(r"\(\S+ line \d+\)$", str(exc).rstrip())  # said already
        return "" if located else found
    except Exception:  # a traceback that cannot be read: no place
        return ""


def split_spec(spec: str) -> tuple[str, str]:
    """``(module or file, function name)`` of a SPEC; the function name follows the last colon.

    Raises:
        IkSpecError: When the SPEC has no ``:function`` part or an empty side.
    """
    where, sep, name = spec.rpartition(":")
    if not sep and _is_path(spec) and not Path(spec).exists():
        raise IkSpecError(f"--ik {spec!r}: no such file or folder {spec}")
    if not sep or not where or not name:
        raise IkSpecError(
            f"--ik {spec!r}: expected package.module:function, path/to/file.py:function, or "
            "a ROS IK_server.py (the file, its scripts folder or its repository)"
        )
    if not name.isidentifier():
        raise IkSpecError(f"--ik {spec!r}: {name!r} is not a Python function name")
    return where, name


def _is_path(where: str) -> bool:
    return where.endswith(".py") or "/" in where or "\\" in where


def _import_file(path: Path, spec: str) -> Any:
    if not path.is_file():
        raise IkSpecError(f"--ik {spec!r}: no such file {path}")
    digest = hashlib.sha1(os.fsencode(path.resolve())).hexdigest()[:12]
    name = f"kr210_user_ik_{path.stem}_{digest}"
    mspec = importlib.util.spec_from_file_location(name, path)
    if mspec is None or mspec.loader is None:
        raise IkSpecError(f"--ik {spec!r}: {path} cannot be imported as a Python module")
    module = importlib.util.module_from_spec(mspec)
    sys.modules[name] = module
    folder = str(path.resolve().parent)
    sys.path.insert(0, folder)
    try:
        mspec.loader.exec_module(module)
    except BaseException:
        sys.modules.pop(name, None)
        raise
    finally:
        try:
            sys.path.remove(folder)
        except ValueError:  # pragma: no cover - the user's code removed it
            pass
    return module


def _import_module(where: str) -> Any:
    """Import the module ``where``, from the folder :func:`find_module` finds it in when that is
    not on ``sys.path`` (the working folder), for the import only."""
    extra = [str(p) for p in spec_files(f"{where}:f").search if str(p) not in sys.path]
    sys.path[:0] = extra
    try:
        return importlib.import_module(where)
    finally:
        for folder in extra:
            if folder in sys.path:
                sys.path.remove(folder)


def import_user_module(where: str, spec: str, option: str = "--ik") -> ModuleType:
    """The module of a SPEC's ``where`` (a file path or a module name), imported here; what
    goes wrong on the way is one line said of ``option SPEC``.

    Raises:
        IkSpecError: A syntax error, a module not found, or an import that raised (said of
            ``option``; the file loader's own refusals are said of ``--ik``).
    """
    said = f"{option} {spec!r}"
    try:
        if _is_path(where):
            return _import_file(Path(where), spec)
        return _import_module(where)
    except IkSpecError:
        raise
    except SyntaxError as exc:
        line = f" line {exc.lineno}" if exc.lineno else ""
        raise IkSpecError(
            f"{said}: syntax error in {exc.filename or where}{line}: {one_line(exc.msg)}"
        ) from None
    except ModuleNotFoundError as exc:
        if exc.name and (where == exc.name or where.startswith(exc.name + ".")):
            raise IkSpecError(f"{said}: no module named {exc.name!r}") from None
        raise IkSpecError(f"{said}: importing {where} raised {describe_exception(exc)}") from None
    except (Exception, SystemExit) as exc:
        raise IkSpecError(f"{said}: importing {where} raised {describe_exception(exc)}") from None


@lru_cache(maxsize=16)
def load_ik(spec: str) -> UserIk:
    """Load the IK function a SPEC names (once per process and SPEC).

    Args:
        spec: ``package.module:function`` or ``path/to/file.py:function``; or a ROS-form
            ``IK_server.py``, its scripts folder or its repository (resolved to the script's
            SPEC, which the result carries).

    Returns:
        The loaded function with its SPEC (a ROS-form server's with its ``batch`` and
        ``notes``).

    Raises:
        IkSpecError: One line saying what is wrong: no such module or file, a syntax error
            (file and line), an exception at import (its message), no such function (with the
            functions the module does define), or a name that is not callable; for a ROS-form
            script also what cannot be read as Python 2 and a ROS package it imports that is
            not here.
    """
    resolved = resolve_spec(spec)
    if resolved != spec:
        return load_ik(resolved)  # one load per resolved SPEC, however it was named
    where, name = split_spec(spec)
    if _is_path(where) and is_ros_form(Path(where)):
        return _load_server(spec, Path(where), name)
    module = import_user_module(where, spec)
    fn = getattr(module, name, None)
    if fn is None:
        defined = sorted(
            k
            for k, v in vars(module).items()
            if callable(v)
            and not k.startswith("_")
            and getattr(v, "__module__", None) == module.__name__
        )
        has = f" (it defines: {', '.join(defined)})" if defined else ""
        raise IkSpecError(f"--ik {spec!r}: {where} has no function {name!r}{has}")
    if not callable(fn):
        raise IkSpecError(f"--ik {spec!r}: {where}.{name} is a {type(fn).__name__}, not a function")
    return UserIk(spec, fn)


def _load_server(spec: str, script: Path, handler: str) -> UserIk:
    """A ROS-form server, started (:class:`~kr210_sim.exercise.server.RosServer`)."""
    from kr210_sim.exercise.server import RosServer

    server = RosServer(script, spec, handler)
    server.start()
    return UserIk(spec, server.solve, batch=server.batch, notes=server.take_notes)


def ik_identity(spec: str) -> dict[str, str | None]:
    """What an IK's results depend on, whatever the spelling of its SPEC: the function's name
    and the SHA-256 of the file it is defined in (None when there is no file to read).

    ``my_ik.py:solve``, ``./my_ik.py:solve`` and ``/abs/my_ik.py:solve`` are one IK; an edited
    file is another.
    """
    where, name = split_spec(resolve_spec(spec))
    source: str | None = None
    if _is_path(where):
        source = where
    else:
        found = find_module(where)
        source = found.origin if found is not None else None
    digest = sha256_regular(Path(source)) if source is not None else None
    return {"function": name, "sha256": digest}


def ik_from_callable(fn: Callable[..., Any]) -> UserIk:
    """A :class:`UserIk` for a Python callable with the ``solve(T, q_ref)`` contract.

    Its SPEC (what reports and messages name) is ``module:qualname``; like any :class:`UserIk`
    it pickles as that SPEC, which re-imports only a module-level function (a lambda or a
    closure cannot be sent to another process).

    Raises:
        IkSpecError: When ``fn`` is not callable.
    """
    if not callable(fn):
        raise IkSpecError(
            f"ik must be a SPEC string or a callable solve(T, q_ref), got a {type(fn).__name__}"
        )
    module = getattr(fn, "__module__", None) or "__main__"
    name = getattr(fn, "__qualname__", None) or type(fn).__name__
    return UserIk(f"{module}:{name}", fn)
