"""The user's own files as a jail shows them: each regular file bound read-only by itself, never a
folder whole.

A folder bound whole would show what the grader's scans refuse: a hard link to an instructor's
0600 file (the jail's user is the grader's uid outside, so the file's owner bits apply), and the
targets of links that leave the user's folder (``kuka_arm/src -> ~instructor``). So
:func:`user_files` walks each of :attr:`~kr210_sim.sandbox.confine.Launch.readable` as the
grader's other scans do (:func:`~kr210_sim.exercise.files.scan`: no link followed, bounded in
depth and entries, hidden folders and ``__pycache__`` left out) and keeps a file only when:

* it is a regular file (not a link, a FIFO or a device), found below the path named, never
  through a link;
* the jail's user could read it as the grader's uid with no capabilities (the owner's, group's or
  others' read bit, as applies);
* it has one link, or anyone may read it (a hard link to a file the user could not read is
  someone else's file);
* it is one of the first :data:`MAX_FILES`.

:class:`Shown` counts what was left out, so the jail's findings say it.
"""

from __future__ import annotations

import os
import site
import stat
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from kr210_sim.errors import ConfigError
from kr210_sim.exercise.files import MAX_ENTRIES, scan
from kr210_sim.util import paths

#: Most of the user's files one jail shows.
MAX_FILES = 2048
#: Folders entered below a folder the user's code is read from.
DEPTH = 8


@dataclass(slots=True)
class Shown:
    """The user's files a jail shows, and what it leaves out.

    Attributes:
        files: The regular files to bind, at their real paths, each once.
        links: Paths named that are links (not followed).
        hard_links: Files with more than one link that the user could not read otherwise.
        unreadable: Files the jail's user could not read.
        over: Files past :data:`MAX_FILES`, or a scan that stopped at its entry bound.
    """

    files: list[Path] = field(default_factory=list)
    links: int = 0
    hard_links: int = 0
    unreadable: int = 0
    over: int = 0

    def findings(self) -> list[str]:
        """What was left out, one line each (none when nothing was)."""
        out = []
        for count, what in (
            (self.links, "named by a link that was not followed"),
            (self.hard_links, "hard-linked to a file the student could not read"),
            (self.unreadable, "unreadable to the student"),
            (self.over, f"past the bound of {MAX_FILES:,} files"),
        ):
            if count:
                out.append(f"{count:,} of the student's files not shown in the jail ({what})")
        return out


def covered(path: Path, roots: list[Path]) -> bool:
    return any(path == r or path.is_relative_to(r) for r in roots)


def python_roots() -> list[Path]:
    """The folders this interpreter runs from: its prefixes (standard library, the environment's
    packages), the folder of the binary it resolves to, and the folders its site-packages'
    ``.pth`` files add to the path (packages installed elsewhere, editable installs)."""
    found = [sys.prefix, sys.base_prefix, sys.exec_prefix, sys.base_exec_prefix]
    found.append(str(Path(sys.executable).resolve().parent))
    found += [str(p) for p in _pth_folders()]
    return list(dict.fromkeys(Path(p).resolve() for p in found if p))


def _pth_folders() -> list[Path]:
    """The existing folders named by the ``.pth`` files of the site-packages (their lines that
    are paths, as ``site`` reads them; ``import`` lines are code, not folders), but one holding
    kr210_sim itself (an editable install's checkout)."""
    found: list[Path] = []
    for where in site.getsitepackages():
        for pth in sorted(Path(where).glob("*.pth")):
            try:
                lines = pth.read_text(errors="replace").splitlines()
            except OSError:
                continue
            for line in lines:
                line = line.strip()
                if not line or line.startswith(("#", "import ", "import\t")):
                    continue
                folder = (Path(where) / line).resolve()
                ours = paths.PACKAGE_DIR.resolve().is_relative_to(folder)  # a checkout: its
                if folder.is_dir() and not ours and str(folder) in map(_resolved, sys.path):
                    found.append(folder)  # package and data are bound alone (package_roots)
    return found


def _resolved(entry: str) -> str:
    try:
        return str(Path(entry).resolve()) if entry else ""
    except (OSError, ValueError):
        return ""


def package_roots() -> list[Path]:
    """kr210_sim's own folders: the package and its data (``assets/``, ``scenes/``), not the
    checkout they may sit in."""
    found = [paths.PACKAGE_DIR, paths.ROOT / "assets", paths.ROOT / "scenes"]
    return list(dict.fromkeys(p.resolve() for p in found if p.exists()))


def user_site() -> Path | None:
    """The user's own site-packages, when this interpreter uses it."""
    if not site.ENABLE_USER_SITE:
        return None
    where = Path(site.getusersitepackages())
    return where.resolve() if where.is_dir() and str(where) in sys.path else None


def readable_by_user(st: os.stat_result) -> bool:
    """Whether the jail's user could read a file of status ``st``: the grader's uid and gid
    with no capabilities (no override of a file's mode)."""
    if st.st_uid == os.geteuid():
        return bool(st.st_mode & stat.S_IRUSR)
    if st.st_gid == os.getegid():
        return bool(st.st_mode & stat.S_IRGRP)
    return bool(st.st_mode & stat.S_IROTH)


def _skip(name: str) -> bool:
    return name == "__pycache__" or name.startswith(".")


def user_files(readable: Sequence[Path]) -> Shown:
    """The files of ``readable`` (files and folders) a jail shows (see the module doc).

    Raises:
        ConfigError: One of them is ``/`` (the jail would see every file).
    """
    shown = Shown()
    seen: set[Path] = set()
    for named in readable:
        path = Path(os.path.abspath(named))
        if path == Path("/"):
            raise ConfigError(
                "cannot jail code read from / (the jail would see every file): move it into a "
                "folder of its own"
            )
        real = path.parent.resolve() / path.name  # the folders above it are the caller's
        try:
            st = real.lstat()
        except OSError:
            continue
        if stat.S_ISLNK(st.st_mode):
            shown.links += 1
            continue
        if stat.S_ISREG(st.st_mode):
            found = [(real, st)]
        elif stat.S_ISDIR(st.st_mode):
            walked = scan(real, DEPTH, _skip, limit=MAX_ENTRIES)
            found = walked.files
            shown.over += 0 if walked.complete else 1
        else:
            continue
        for file, fst in found:
            if file in seen:
                continue
            seen.add(file)
            if not readable_by_user(fst):
                shown.unreadable += 1
            elif fst.st_nlink > 1 and not fst.st_mode & stat.S_IROTH:
                shown.hard_links += 1
            elif len(shown.files) >= MAX_FILES:
                shown.over += 1
            else:
                shown.files.append(file)
    return shown
