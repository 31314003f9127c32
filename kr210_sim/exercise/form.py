"""Tell the original exercise's form from ours, and find the server in a submission.

A ROS-form submission is a ROS service script, ``kuka_arm/scripts/IK_server.py`` in a student's
copy of the exercise's repository: it imports ``rospy`` (or the exercise's ``kuka_arm.srv``) and
answers ``handle_calculate_IK(req)``. Ours is a module with ``solve(T, q_ref)``. The form is told
from the file's text, without running it and without a flag (:func:`is_ros_form`).

:func:`resolve_spec` turns what a user names with ``--ik`` or ``grade`` into a SPEC: a
repository, its ``scripts`` folder or the script itself becomes ``path/IK_server.py:
handle_calculate_IK``, which pickles, prints and replays like any SPEC; a ``.py`` file of our
form named without ``:function`` becomes ``path/file.py:solve``.
"""

from __future__ import annotations

import os
import re
import stat
from collections.abc import Callable
from pathlib import Path

from kr210_sim.errors import IkSpecError
from kr210_sim.exercise.files import read_head, read_regular, scan

#: The handler every IK server defines (the SPEC's function; the fallback when the script
#: registers none).
HANDLER = "handle_calculate_IK"
#: The script's name in the exercise.
SERVER = "IK_server.py"
#: Where a repository keeps it, first choice first.
PLACES = ("kuka_arm/scripts", "scripts", ".")
#: The function a ``.py`` file of our form is named by.
OUR_FUNCTION = "solve"
#: Most of a file read to tell its form [bytes].
READ = 1 << 21
#: How deep below a folder a server is looked for.
DEPTH = 4
#: Most files, and bytes, of a script's folder copied into its working folder.
SEED_FILES = 200
SEED_BYTES = 128 << 20
#: How deep below the script's folder files are copied.
SEED_DEPTH = 4

_ROS_IMPORT = re.compile(
    rb"^[ \t]*(?:import[ \t]+(?:rospy|kuka_arm)\b"
    rb"|from[ \t]+(?:rospy|kuka_arm)[\w.]*[ \t]+import\b)",
    re.MULTILINE,
)
_SERVICE = re.compile(rb"rospy\.Service\s*\(|\bdef[ \t]+handle_calculate_IK\b")


def is_ros_form(path: Path) -> bool:
    """Whether the Python file ``path`` is a ROS-form server: it imports ``rospy`` or
    ``kuka_arm`` and registers a service or defines ``handle_calculate_IK`` (False for a file
    that cannot be read)."""
    try:
        head = read_head(path, READ)
    except OSError:
        return False
    return bool(_ROS_IMPORT.search(head) and _SERVICE.search(head))


def _hidden(name: str) -> bool:
    return name.startswith((".", "_"))


def find_server(folder: Path) -> Path | None:
    """The ROS-form server in ``folder``: ``IK_server.py`` in ``kuka_arm/scripts``,
    ``scripts`` or the folder itself; else the one ``IK_server.py`` below it (at most
    :data:`DEPTH` folders down, a ``kuka_arm/scripts`` one first); else the one ROS-form
    script in a ``scripts`` folder. None when there is none (or no single one). Below the
    three places, only regular files count, and the search follows no link and looks at a
    bounded number of entries (:func:`~kr210_sim.exercise.files.scan`)."""
    for place in PLACES:
        path = folder / place / SERVER
        if _is(path, Path.is_file):  # a link here is found, for the roster to say where it leads
            return path
    found = sorted(
        p for p, _ in scan(folder, DEPTH, _hidden).files if p.name == SERVER and p.parent != folder
    )
    preferred = [p for p in found if p.parent.match("kuka_arm/scripts")]
    for group in (preferred, found):
        if len(group) == 1:
            return group[0]
    scripts = [folder / "kuka_arm" / "scripts", folder / "scripts"]
    servers = [
        p for s in scripts for p, _ in scan(s, 0).files if p.suffix == ".py" and is_ros_form(p)
    ]
    return servers[0] if len(servers) == 1 else None


def resolve_spec(text: str) -> str:
    """The SPEC for ``text``: a repository, ``scripts`` folder or ROS-form script becomes
    ``path/IK_server.py:handle_calculate_IK``, a ``.py`` file of our form without
    ``:function`` becomes ``path/file.py:solve``; anything else is returned as it is.

    Raises:
        IkSpecError: A folder with no ROS-form server in it.
    """
    where, sep, name = text.rpartition(":")
    if sep and where and name.isidentifier():
        return text  # a SPEC already
    path = Path(text)
    if _is(path, Path.is_dir):
        server = find_server(path)
        if server is None:
            raise IkSpecError(
                f"--ik {text!r}: no {SERVER} in this folder (looked in kuka_arm/scripts, scripts, "
                f"the folder itself and {DEPTH} folders down): name the script itself"
            )
        return f"{server}:{HANDLER}"
    if path.suffix == ".py" and _is(path, Path.is_file):
        return f"{path}:{HANDLER if is_ros_form(path) else OUR_FUNCTION}"
    return text


def _is(path: Path, test: Callable[[Path], bool]) -> bool:
    """``test(path)``, False for a path the system refuses (a name too long, say)."""
    try:
        return test(path)
    except (OSError, ValueError):
        return False


def _seedable(st: os.stat_result) -> bool:
    """Whether a student's file may be copied into its working folder by the grader: only what
    the jail's user could read of it (the grader's uid, its capabilities dropped: no override
    of a file's mode; an instructor's 0600 file owned by another user is not), and not a hard
    link (it may be anyone's file, the roster checks only symbolic links)."""
    if st.st_nlink != 1:
        return False
    if st.st_uid == os.geteuid():
        return bool(st.st_mode & stat.S_IRUSR)
    if st.st_gid == os.getegid():
        return bool(st.st_mode & stat.S_IRGRP)
    return bool(st.st_mode & stat.S_IROTH)


def seed_scratch(script: Path, scratch: Path, root: Path | None = None) -> int:
    """Copy the student's files beside ``script`` (its folder, subfolders too, without
    ``__pycache__``, hidden folders and compiled files) into ``scratch``, its working folder, so
    that it reads them by relative paths as it did under ``rosrun``; a file already there (one
    the script wrote) is kept. Only the student's own files: ``root`` alone when it is a file (a
    server handed in as one file of a class folder), else what of the script's folder lies in
    ``root``; and of those only what the student could read in its jail (:func:`_seedable`).
    Links are not followed, and at most :data:`SEED_FILES` files and :data:`SEED_BYTES` bytes
    are copied, the smallest first.

    Args:
        script: The server script.
        scratch: Its working folder.
        root: The student's own files, a file or a folder (None: the script's folder).

    Returns:
        The files copied.
    """
    folder = script.resolve().parent
    own = folder if root is None else root.resolve()
    if own.is_file():
        found = scan(own.parent, 0).files
        found = [(p, st) for p, st in found if p.name == own.name]
    elif folder.is_relative_to(own):
        skip = _hidden_or_cache
        found = scan(folder, SEED_DEPTH, skip, limit=4 * SEED_FILES).files
    else:
        found = []
    candidates = sorted(
        (st.st_size, p) for p, st in found if p.suffix not in (".pyc", ".pyo") and _seedable(st)
    )
    copied, total = 0, 0
    for size, path in candidates:
        if copied >= SEED_FILES or total + size > SEED_BYTES:
            break
        target = scratch / path.relative_to(own.parent if own.is_file() else folder)
        if target.exists():
            continue
        try:
            data = read_regular(path, SEED_BYTES - total)
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(data)
        except OSError:
            continue
        copied, total = copied + 1, total + len(data)
    return copied


def _hidden_or_cache(name: str) -> bool:
    return name == "__pycache__" or name.startswith(".")
