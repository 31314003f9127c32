"""The students a ``grade`` call names: SUBMISSION arguments to named students.

A SUBMISSION is a SPEC (``path/file.py:function`` or ``package.module:function``), a ``.py``
file (its ``solve``), or a folder: each ``.py`` file in it is one student, named by the file,
and each subfolder is one student, named by the folder, whose ``solve`` is in
:data:`STUDENT_MODULE` (or in the folder's only ``.py`` file). A subfolder that holds the
original exercise's ROS server instead (a student's repository: ``kuka_arm/scripts/
IK_server.py``, found by :func:`~kr210_sim.exercise.form.find_server`) is that student, graded
by its ``handle_calculate_IK``; so is a ``.py`` file that is such a server, and a SUBMISSION
that is one repository (its ``IK_server.py`` in ``kuka_arm/scripts``, ``scripts`` or itself).
Files and folders whose names start with ``.`` or ``_`` are skipped; so is any other file,
except three that look like a submission and cannot be graded, which are students with the
verdict ``error`` and a detail that says what to do: a symbolic link to nothing, a file ending
in ``.PY`` (any case but ``.py``: Python imports only ``.py`` files) and a Jupyter notebook
(``.ipynb``).

A student's name is shown and written as :func:`~kr210_sim.grading.record.printable` text: the
undecodable bytes of a file name as ``\\xNN``, control characters as escapes.
"""

from __future__ import annotations

import itertools
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from kr210_sim.errors import ConfigError
from kr210_sim.exercise.files import MAX_ENTRIES
from kr210_sim.exercise.form import HANDLER, PLACES, SERVER, find_server, resolve_spec
from kr210_sim.grading.record import printable
from kr210_sim.sandbox.user_ik import split_spec

#: The module a student's folder keeps its ``solve`` in.
STUDENT_MODULE = "ik.py"
#: The function a ``.py`` file or a folder is graded by.
STUDENT_FUNCTION = "solve"
#: The suffix of a Jupyter notebook.
NOTEBOOK = ".ipynb"


@dataclass(frozen=True, slots=True)
class Student:
    """One submission to grade.

    Attributes:
        name: File or folder name (a ``.py`` file's without ``.py``), as shown.
        spec: SPEC of its ``solve`` ("" when ``problem`` is set).
        problem: Why it cannot be graded (verdict ``error``), or "".
        root: The student's own files, all its code may read in its jail: its folder (a
            folder student), its file (a ``.py`` file or a SPEC's file: never the folder
            beside it, which may hold other students), or "" (a module SPEC: where the module
            is found).
    """

    name: str
    spec: str
    problem: str = ""
    root: str = ""


def _shown(path: Path | str) -> str:
    return printable(str(path), name=True)


def _not_python(path: Path) -> str:
    """Why a file that looks like a submission cannot be graded, with what to do ("" when it
    does not look like one)."""
    if path.suffix == NOTEBOOK:
        return (
            f"{_shown(path)} is a Jupyter notebook: export its code as a .py file "
            f"(jupyter nbconvert --to script {_shown(path.name)}) and grade that"
        )
    if path.suffix.lower() == ".py" and path.suffix != ".py":
        return (
            f"{_shown(path)} ends in {path.suffix!r}: Python imports only files ending in "
            f"'.py'; rename it {_shown(path.stem)}.py"
        )
    return ""


def _dangling(path: Path) -> str:
    """Why a symbolic link to nothing is no submission ("" when ``path`` is not one)."""
    if not path.is_symlink() or path.exists():
        return ""
    try:
        to = os.readlink(path)
    except OSError:
        to = "?"
    return f"{_shown(path)} is a symbolic link to {_shown(to)}, which does not exist"


def _leads_out(path: Path, folder: Path) -> str:
    """Why the submission file ``path`` of the student folder ``folder`` is not graded when it,
    or a folder on its way, is a symbolic link out of ``folder`` ("" when it is not): its jail
    shows it only ``folder``, and the files beside what the link leads to would be copied in."""
    target = path.resolve()
    if target.is_relative_to(folder.resolve()):
        return ""
    return (
        f"{_shown(path)} leads out of its student's folder {_shown(folder)}, to "
        f"{_shown(target)} (a symbolic link): not graded (copy the file into the folder)"
    )


def _in_folder(name: str, path: Path, function: str, folder: Path) -> Student:
    """The student of folder ``folder`` graded by ``path``'s ``function``, or an error student
    when ``path`` leads out of the folder."""
    if why := _leads_out(path, folder):
        return Student(name, "", why)
    return Student(name, f"{path}:{function}", root=str(folder))


def _folder_student(folder: Path) -> Student:
    name = _shown(folder.name)
    module = folder / STUDENT_MODULE
    if module.is_file():
        return _in_folder(name, module, STUDENT_FUNCTION, folder)
    if why := _dangling(module):
        return Student(name, "", why)
    server = find_server(folder)
    if server is not None:  # a repository of the original exercise
        return _in_folder(name, server, HANDLER, folder)
    listed = itertools.islice(folder.iterdir(), MAX_ENTRIES)  # a million files: bounded
    entries = sorted(p for p in listed if not p.name.startswith((".", "_")))
    files = [p for p in entries if p.suffix == ".py" and p.is_file()]
    if len(files) == 1:
        return _in_folder(name, files[0], STUDENT_FUNCTION, folder)
    found = f"{len(files)} .py files" if files else "no .py file"
    if not files:  # say what is there instead, when it looks like a submission
        whys = [why for p in entries if (why := _not_python(p) or _dangling(p))]
        found += f"; {whys[0]}" if whys else ""
    return Student(name, "", f"no {STUDENT_MODULE} in {_shown(folder)} ({found})")


def _links_out(path: Path) -> str:
    """Why a class folder's entry that is a symbolic link out of that folder is no submission
    ("" when it is none): its jail would show it what the link leads to (``alice -> /home/you``
    from an unpacked archive)."""
    if not path.is_symlink() or not path.exists():
        return ""
    target = path.resolve()
    if target.is_relative_to(path.parent.resolve()):
        return ""
    return (
        f"{_shown(path)} is a symbolic link out of its class folder, to {_shown(target)}: "
        "not graded (copy the submission into the class folder)"
    )


def _entry_student(path: Path) -> Student | None:
    """The student a class folder's entry is (None: not a submission)."""
    if path.name.startswith((".", "_")):
        return None
    if (why := _links_out(path)) and (path.is_dir() or path.suffix == ".py"):
        return Student(_shown(path.stem if path.suffix == ".py" else path.name), "", why)
    if path.is_dir():
        return _folder_student(path)
    if why := _dangling(path):
        if path.suffix.lower() not in (".py", NOTEBOOK, ""):
            return None
        return Student(_shown(path.stem if path.suffix == ".py" else path.name), "", why)
    if path.suffix == ".py" and path.is_file():
        return Student(_shown(path.stem), resolve_spec(str(path)), root=str(path))
    if why := _not_python(path):
        return Student(_shown(path.name), "", why)
    return None


def _repository(path: Path) -> bool:
    """Whether the folder ``path`` is one repository of the original exercise (its server in
    ``kuka_arm/scripts``, ``scripts`` or itself), not a class folder."""
    return any((path / place / SERVER).is_file() for place in PLACES)


def _spec_student(text: str) -> Student:
    """The student a SPEC names.

    Raises:
        ConfigError: A path that is not a ``.py`` file, or neither a file nor a module name.
        IkSpecError: A SPEC with no ``:function`` part.
    """
    where, function = split_spec(text)
    if where.endswith(".py") or "/" in where or os.sep in where:
        path = Path(where)
        if path.suffix != ".py":
            near = Path(f"{where}.py")
            hint = f" (did you mean {_shown(near)}:{function}?)" if near.is_file() else ""
            raise ConfigError(
                f"{_shown(text)}: {_shown(where)} is not a .py file; a SPEC is "
                f"path/file.py:function or package.module:function{hint}"
            )
        if not path.is_file():
            raise ConfigError(f"{_shown(text)}: no such file {_shown(where)}")
        return Student(_shown(path.stem), text, root=str(path))
    if not all(part.isidentifier() for part in where.split(".")):
        raise ConfigError(
            f"{_shown(text)}: {_shown(where)!r} is neither a .py file nor a module name; a SPEC "
            "is path/file.py:function or package.module:function"
        )
    return Student(where, text)


def find_students(submissions: Sequence[str | Path]) -> list[Student]:
    """The students the SUBMISSION arguments name, in the order given (folders sorted by name).

    Raises:
        ConfigError: No SUBMISSION; one that is not a path or a SPEC (str or Path), does not
            exist, is not a ``.py`` file, a folder or a SPEC; a folder with no student in it; or
            two students with one name.
        IkSpecError: A SPEC with no ``:function`` part.
    """
    if isinstance(submissions, str | Path) or not isinstance(submissions, Sequence):
        raise ConfigError(f"submissions must be a list of paths or SPECs, got {submissions!r}")
    if not submissions:
        raise ConfigError("no submission: name a class folder, a .py file or a SPEC")
    for given in submissions:
        if not isinstance(given, str | Path):
            raise ConfigError(f"a submission must be a path or a SPEC (str or Path), got {given!r}")
    students: list[Student] = []
    for given in submissions:
        text = str(given)
        path = Path(text)
        if path.is_dir() and _repository(path):
            students.append(_folder_student(path))
        elif path.is_dir():
            found = [s for p in sorted(path.iterdir()) if (s := _entry_student(p)) is not None]
            if not found:
                raise ConfigError(
                    f"{_shown(text)}: no student in this folder (no .py file, no subfolder)"
                )
            students.extend(found)
        elif path.suffix == ".py":
            if not path.is_file():
                raise ConfigError(_dangling(path) or f"{_shown(text)}: no such file")
            students.append(Student(_shown(path.stem), resolve_spec(text), root=text))
        elif path.exists() and _not_python(path):
            raise ConfigError(_not_python(path))
        elif ":" in text:
            students.append(_spec_student(text))
        else:
            raise ConfigError(
                f"{_shown(text)}: not a folder, a .py file or a SPEC (path/file.py:function)"
            )
    seen: dict[str, int] = {}
    for s in students:
        seen[s.name] = seen.get(s.name, 0) + 1
    twice = sorted(n for n, k in seen.items() if k > 1)
    if twice:
        raise ConfigError(f"two students named {twice[0]!r}: grade them in separate calls")
    return students
