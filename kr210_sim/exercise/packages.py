"""The student's own ROS message and service types, built from the ``.msg`` and ``.srv`` files of
the catkin packages in their repository, as ``catkin_make`` generated them.

An IK server may publish a message of its own package (``from kuka_arm.msg import
Float64List``, with ``kuka_arm/msg/Float64List.msg`` holding ``float64[] data``) or import one of
a sibling package. Under ROS, genpy made a module ``<package>.msg`` (and ``<package>.srv``) of
each package's definitions; here :class:`PackageFinder` makes the same modules on import, with
the classes of :mod:`kr210_sim.exercise.messages` (built, compared and printed as genpy's):

* a ``.msg`` file: one ``type name`` field a line, ``type NAME=value`` constants, ``#``
  comments; a field's type is a built-in one, a message of the same package (``Point``) or of
  another (``geometry_msgs/Pose``), with ``[]`` or ``[N]`` for arrays;
* a ``.srv`` file: the request's fields, ``---``, the response's: ``<Name>Request``,
  ``<Name>Response`` and the service class ``<Name>`` (what ``rospy.Service`` takes).

The packages are the folders, next to the script's own catkin package and including it, that
hold a ``msg`` or ``srv`` folder; a package is named by its ``package.xml`` (else its folder).
``kuka_arm.srv`` stays ours (the exercise's ``CalculateIK``); a definition that cannot be read
is one line naming the file and the line.
"""

from __future__ import annotations

import importlib.abc
import importlib.machinery
import itertools
import os
import re
import sys
import types
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from kr210_sim.errors import IkSpecError
from kr210_sim.exercise import messages
from kr210_sim.exercise.files import MAX_ENTRIES, TooLarge, read_regular, scan

#: The modules the shims already provide whole (never made from the student's files).
KEPT = frozenset({"kuka_arm.srv"})
#: Most of a ``package.xml``, a ``.msg`` or a ``.srv`` file read (they are a few kB) [bytes].
READ_LIMIT = 1 << 20
#: Most message or service files of one package read.
MAX_DEFINITIONS = 1000
#: A field or constant line of a definition.
_LINE = re.compile(
    r"^(?P<type>[A-Za-z][\w/]*(?:\[\d*\])?)\s+(?P<name>\w+)\s*(?:=\s*(?P<value>.*))?$"
)


def package_folders(script: Path) -> dict[str, Path]:
    """The catkin packages beside ``script``'s own (and it) that define messages or services,
    by package name (see the module doc)."""
    folder = script.resolve().parent
    own = folder.parent if folder.name in ("scripts", "nodes", "src") else folder
    found: dict[str, Path] = {}
    for candidate in sorted({own, *_children(own.parent)}):
        if (candidate / "msg").is_dir() or (candidate / "srv").is_dir():
            found.setdefault(_package_name(candidate), candidate)
    return found


def definition_files(script: Path) -> list[Path]:
    """What a process serving ``script`` must be able to read for :func:`package_folders`: each
    package's ``msg`` and ``srv`` folders and its ``package.xml``."""
    return [
        folder / name
        for folder in package_folders(script).values()
        for name in ("msg", "srv", "package.xml")
        if (folder / name).exists()
    ]


def _children(folder: Path) -> list[Path]:
    """The folders in ``folder`` (not links to folders), a bounded number."""
    try:
        with os.scandir(folder) as it:
            entries = list(itertools.islice(it, MAX_ENTRIES))
    except OSError:
        return []
    return [Path(e.path) for e in entries if _is_dir(e)]


def _is_dir(entry: os.DirEntry[str]) -> bool:
    try:
        return entry.is_dir(follow_symlinks=False)
    except OSError:
        return False


def read_definition(path: Path) -> str:
    """The text of a student's ``package.xml``, ``.msg`` or ``.srv`` file: a regular file, at
    most :data:`READ_LIMIT` bytes.

    Raises:
        IkSpecError: It is larger (one line naming it), or not a regular file.
        OSError: It cannot be read.
    """
    try:
        data = read_regular(path, READ_LIMIT)
    except TooLarge:
        size = path.lstat().st_size
        raise IkSpecError(
            f"{path} holds {size:,} bytes, more than the {READ_LIMIT:,} read: not read "
            f"(a {path.name if path.suffix == '.xml' else path.suffix + ' file'} is a few kB)"
        ) from None
    return data.decode(errors="replace")


def _package_name(folder: Path) -> str:
    """The name ``folder``'s ``package.xml`` gives its package (else the folder's name).

    Raises:
        IkSpecError: Its ``package.xml`` is too large to read.
    """
    try:
        text = read_definition(folder / "package.xml")
    except OSError:
        return folder.name
    match = re.search(r"<name>\s*([\w-]+)\s*</name>", text)
    return match.group(1) if match else folder.name


def _definitions(folder: Path, suffix: str) -> list[Path]:
    """The ``*<suffix>`` regular files of ``folder`` (a bounded number, no links)."""
    found = scan(folder, 0, limit=MAX_DEFINITIONS).files
    return sorted(p for p, _ in found if p.suffix == suffix)


def _constant(kind: str, value: str) -> Any:
    if kind == "string":
        return value.strip()
    value = value.split("#")[0].strip()
    if kind in ("float32", "float64"):
        return float(value)
    if kind == "bool":
        return value not in ("0", "False", "false")
    return int(value)


def parse(text: str, where: str) -> tuple[list[tuple[str, str]], dict[str, Any]]:
    """The fields (``(type, name)`` pairs) and constants of one definition (a ``.msg`` file, or
    one half of a ``.srv``); ``where`` names it in errors ("Foo.msg")."""
    fields: list[tuple[str, str]] = []
    constants: dict[str, Any] = {}
    for number, raw in enumerate(text.splitlines(), start=1):
        kind_part = raw.split("=", 1)
        is_string_constant = len(kind_part) == 2 and kind_part[0].split()[:1] == ["string"]
        line = raw.strip() if is_string_constant else raw.split("#")[0].strip()
        if not line:
            continue
        m = _LINE.match(line)
        if m is None:
            raise IkSpecError(f"{where} line {number}: cannot read {raw.strip()!r} as a field")
        if m.group("value") is not None:
            try:
                constants[m.group("name")] = _constant(m.group("type"), m.group("value"))
            except ValueError:
                raise IkSpecError(
                    f"{where} line {number}: {m.group('value').strip()!r} is no "
                    f"{m.group('type')} constant"
                ) from None
        else:
            fields.append((m.group("type"), m.group("name")))
    return fields, constants


def _build(package: str, name: str, text: str, where: str) -> type[messages.Message]:
    fields, constants = parse(text, where)
    spec = "; ".join(f"{kind} {field}" for kind, field in fields)
    return messages.message(f"{package}/{name}", spec, **constants)


def msg_module(fullname: str, folder: Path) -> types.ModuleType:
    """The module ``<package>.msg``: a class per ``folder/msg/*.msg`` file."""
    package = fullname.rsplit(".", 1)[0]
    module = types.ModuleType(fullname)
    files = _definitions(folder / "msg", ".msg")
    pending = {f.stem: f for f in files}
    # a message naming another of its package is built after it (as genpy ordered them)
    while pending:
        progress = False
        for name, path in list(pending.items()):
            text = read_definition(path)
            needs = {k.split("[")[0] for k, _ in parse(text, path.name)[0]} & set(pending)
            if needs - {name}:
                continue
            setattr(module, name, _build(package, name, text, path.name))
            del pending[name]
            progress = True
        if not progress:  # a cycle: genpy could not build it either
            raise IkSpecError(f"{', '.join(sorted(pending))}.msg: the messages name each other")
    module.__all__ = [f.stem for f in files]  # type: ignore[attr-defined]
    return module


def srv_module(fullname: str, folder: Path) -> types.ModuleType:
    """The module ``<package>.srv``: for each ``folder/srv/*.srv``, its request, response and
    service classes."""
    package = fullname.rsplit(".", 1)[0]
    module = types.ModuleType(fullname)
    names: list[str] = []
    for path in _definitions(folder / "srv", ".srv"):
        text = read_definition(path)
        request, sep, response = text.partition("\n---")
        if not sep and text.startswith("---"):
            request, response = "", text[3:]
        req = _build(package, f"{path.stem}Request", request, path.name)
        res = _build(package, f"{path.stem}Response", response.partition("\n")[2], path.name)
        service = type(
            path.stem,
            (),
            {"_type": f"{package}/{path.stem}", "_request_class": req, "_response_class": res},
        )
        for cls in (req, res, service):
            setattr(module, cls.__name__, cls)
        names += [req.__name__, res.__name__, path.stem]
    module.__all__ = names  # type: ignore[attr-defined]
    return module


class _Loader(importlib.abc.Loader):
    def __init__(self, folder: Path | None) -> None:
        self.folder = folder

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> types.ModuleType:
        name = spec.name
        if self.folder is None:  # the package itself: a namespace for its msg and srv
            module = types.ModuleType(name)
            module.__path__ = []
            return module
        if name.endswith(".msg"):
            return msg_module(name, self.folder)
        return srv_module(name, self.folder)

    def exec_module(self, module: types.ModuleType) -> None:
        """Everything was made in :meth:`create_module`."""


class PackageFinder(importlib.abc.MetaPathFinder):
    """Makes ``<package>``, ``<package>.msg`` and ``<package>.srv`` for the packages given to
    :meth:`add` (see the module doc); one per process."""

    def __init__(self) -> None:
        self.packages: dict[str, Path] = {}

    def add(self, packages: dict[str, Path]) -> None:
        """Serve these packages (name -> folder) from now on."""
        self.packages.update(packages)

    def find_spec(self, fullname: str, path: Any = None, target: Any = None) -> Any:
        top, _, sub = fullname.partition(".")
        folder = self.packages.get(top)
        if folder is None or fullname in KEPT:
            return None
        if not sub:
            if importlib.machinery.PathFinder.find_spec(top, path) is not None:
                return None  # the package is importable (a shim, or the student's own)
            return importlib.machinery.ModuleSpec(fullname, _Loader(None), is_package=True)
        if sub in ("msg", "srv") and (folder / sub).is_dir():
            return importlib.machinery.ModuleSpec(fullname, _Loader(folder))
        return None


def install(script: Path, extra: Sequence[Path] = ()) -> PackageFinder:
    """Serve the message packages beside ``script`` (and in ``extra`` folders) from now on."""
    finder = next((f for f in sys.meta_path if isinstance(f, PackageFinder)), None)
    if finder is None:
        finder = PackageFinder()
        sys.meta_path.insert(0, finder)
    finder.add(package_folders(script))
    for folder in extra:
        finder.add({_package_name(folder): folder})
    return finder
