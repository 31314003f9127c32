"""A student's files, read as hostile input: bounded scans and reads that follow no link.

Everything the grader does outside the jail with a student's files goes through here: a scan
(:func:`scan`) walks with :func:`os.scandir` and ``follow_symlinks=False``, so a link (``l1 ->
.``, ``key -> /root``) is neither a folder to enter nor a file to read; it stops at a depth and
at a number of entries looked at, in all. A read (:func:`read_regular`) opens with
``O_NOFOLLOW | O_NONBLOCK`` and reads only what :func:`os.fstat` says is a regular file (a FIFO
named ``IK_helper.py`` does not block it), at most a given number of bytes.
"""

from __future__ import annotations

import hashlib
import os
import stat
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["MAX_ENTRIES", "Scan", "TooLarge", "read_head", "read_regular", "scan", "sha256_regular"]

#: Most entries (files, folders, links) one scan looks at, in all.
MAX_ENTRIES = 20_000


class TooLarge(OSError):
    """A student's file larger than what may be read of it."""


@dataclass(slots=True)
class Scan:
    """What a scan found.

    Attributes:
        files: The regular files found (not links), with their status, in name order per folder.
        visited: Entries looked at (files, folders, links, others).
        complete: False when the scan stopped at its entry bound.
    """

    files: list[tuple[Path, os.stat_result]] = field(default_factory=list)
    visited: int = 0
    complete: bool = True


def scan(
    folder: Path,
    depth: int,
    skip: Callable[[str], bool] = lambda name: False,
    limit: int = MAX_ENTRIES,
) -> Scan:
    """The regular files below ``folder``, breadth first, following no link.

    Args:
        folder: The folder to scan (a link or a non-folder gives nothing).
        depth: Folders entered below ``folder`` (0: its own files only).
        skip: Whether a folder of this name is left out (``__pycache__``, hidden ones).
        limit: Most entries looked at, in all.
    """
    found = Scan()
    try:
        if not stat.S_ISDIR(folder.lstat().st_mode):
            return found
    except (OSError, ValueError):
        return found
    level: list[Path] = [folder]
    for below in range(depth + 1):
        deeper: list[Path] = []
        for here in level:
            try:
                with os.scandir(here) as it:
                    entries = []
                    for entry in it:
                        found.visited += 1
                        if found.visited > limit:
                            found.complete = False
                            break
                        entries.append(entry)
            except OSError:
                continue
            for entry in sorted(entries, key=lambda e: e.name):
                try:
                    st = entry.stat(follow_symlinks=False)
                except OSError:
                    continue
                if stat.S_ISDIR(st.st_mode):
                    if below < depth and not skip(entry.name):
                        deeper.append(Path(entry.path))
                elif stat.S_ISREG(st.st_mode):
                    found.files.append((Path(entry.path), st))
            if not found.complete:
                return found
        level = deeper
    return found


def _open_regular(path: Path, follow: bool) -> tuple[int, os.stat_result]:
    """A descriptor of the regular file ``path`` and its status, opened without blocking.

    Raises:
        OSError: It cannot be opened, or is no regular file (a FIFO, a folder, a device; a link
            unless ``follow``).
    """
    flags = os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC | (0 if follow else os.O_NOFOLLOW)
    fd = os.open(path, flags)
    st = os.fstat(fd)
    if not stat.S_ISREG(st.st_mode):
        os.close(fd)
        raise OSError(f"{path} is not a regular file")
    return fd, st


def read_head(path: Path, size: int) -> bytes:
    """At most the first ``size`` bytes of the regular file ``path`` (a link to one is
    followed: a user may name a file by one), without blocking on a FIFO or a device.

    Raises:
        OSError: It cannot be opened, or is no regular file.
    """
    fd, _ = _open_regular(path, follow=True)
    try:
        return _read(fd, size)
    finally:
        os.close(fd)


def read_regular(path: Path, limit: int) -> bytes:
    """The bytes of the regular file ``path``, read without following a link at its end and
    without blocking on a FIFO or a device.

    Raises:
        TooLarge: It holds more than ``limit`` bytes.
        OSError: It cannot be opened, or is no regular file (a link, a FIFO, a folder, ...).
    """
    fd, st = _open_regular(path, follow=False)
    try:
        if st.st_size > limit:
            raise TooLarge(f"{path} holds {st.st_size:,} bytes, more than the {limit:,} read")
        data = _read(fd, limit + 1)
        if len(data) > limit:
            raise TooLarge(f"{path} holds more than the {limit:,} bytes read")
        return data
    finally:
        os.close(fd)


def sha256_regular(path: Path) -> str | None:
    """The SHA-256 of the regular file ``path`` (a link to one is followed), read in chunks,
    without blocking on a FIFO or a device; None when it is no regular file or unreadable."""
    try:
        fd, _ = _open_regular(path, follow=True)
    except OSError:
        return None
    try:
        digest = hashlib.sha256()
        while chunk := os.read(fd, 1 << 20):
            digest.update(chunk)
        return digest.hexdigest()
    except OSError:
        return None
    finally:
        os.close(fd)


def _read(fd: int, size: int) -> bytes:
    chunks: list[bytes] = []
    while size > 0 and (chunk := os.read(fd, min(size, 1 << 20))):
        chunks.append(chunk)
        size -= len(chunk)
    return b"".join(chunks)
