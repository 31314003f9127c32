"""Output files: checked before any work starts, written atomically, never clobbering inputs.

Every file a command writes goes through here:

* :func:`check_writable` refuses, up front and in one line, a path that cannot be written (a
  folder, a missing or read-only parent, a block device, a socket) or that names one of
  kr210_sim's own files (its code, the URDF, the meshes, the scenes and cell files): every
  command's outputs go through it before anything runs.
* :func:`check_distinct` refuses two outputs at one path, or an output at the path of an input
  the user gave (the scene, a cell file, the IK file, a recording): a typo must never overwrite
  what a run reads.
* :func:`atomic_path` yields a temporary path beside the destination and moves the finished file
  into place: a failed or interrupted write leaves the destination as it was. The file gets the
  mode a plain ``open`` would give it (the umask's), or keeps the mode of the file it replaces.
* A symbolic link is written through (its target is replaced, the link stays); a character
  device or a FIFO (``/dev/null``, ``/dev/stdout``, a pipe) is written through directly, never
  replaced by a regular file.
"""

from __future__ import annotations

import contextlib
import json
import os
import stat
import tempfile
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

from kr210_sim.errors import ConfigError
from kr210_sim.util.paths import ASSETS_DIR, PACKAGE_DIR, SCENES_DIR


def _umask() -> int:
    """The process's umask (read without changing it where /proc allows)."""
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)  # pragma: no cover - systems without /proc
    os.umask(mask)  # pragma: no cover
    return mask  # pragma: no cover


def is_stream(path: Path | str) -> bool:
    """Whether ``path`` (after symbolic links) is a character device or a FIFO, written through
    rather than replaced."""
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return False
    return stat.S_ISCHR(mode) or stat.S_ISFIFO(mode)


def own_file(path: Path | str) -> bool:
    """Whether ``path`` (after symbolic links) is an existing file of kr210_sim itself: inside
    the package, the robot's assets or the scenes folder."""
    try:
        if not os.path.isfile(path):
            return False
        target = Path(os.path.realpath(path))
    except OSError:  # pragma: no cover - a path the system cannot resolve
        return False
    for folder in (PACKAGE_DIR, ASSETS_DIR, SCENES_DIR):
        if target.is_relative_to(os.path.realpath(folder)):
            return True
    return False


def check_writable(path: Path | str) -> Path:
    """Fail early, with a one-line message, when ``path`` cannot be written.

    Creates the parent folder when it is missing.

    Args:
        path: The file to be written.

    Returns:
        ``path`` as a :class:`Path`.

    Raises:
        ConfigError: When ``path`` is a folder, a block device or a socket, one of kr210_sim's
            own files (:func:`own_file`), or its folder is missing and cannot be made, or is not
            writable.
    """
    p = Path(path)
    if str(path) == "":
        raise ConfigError("an output path is empty")
    if p.is_dir():
        raise ConfigError(f"{p} is a folder; give a file path")
    if own_file(p):
        raise ConfigError(
            f"{p} is one of kr210_sim's own files (its code, URDF, meshes or scenes): "
            "give another path"
        )
    if p.exists():
        mode = os.stat(p).st_mode
        if stat.S_ISCHR(mode) or stat.S_ISFIFO(mode):
            if not os.access(p, os.W_OK):
                raise ConfigError(f"cannot write {p}: permission denied")
            return p
        if not stat.S_ISREG(mode):
            raise ConfigError(f"cannot write {p}: it is not a regular file, a pipe or a device")
    target = Path(os.path.realpath(p))
    parent = target.parent
    if parent.exists() and not parent.is_dir():
        raise ConfigError(f"cannot write {p}: {parent} is a file, not a folder")
    if not parent.exists():
        try:
            parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise ConfigError(f"cannot create the folder {parent}: {exc.strerror}") from exc
    if not os.access(parent, os.W_OK):
        raise ConfigError(f"cannot write to {parent}: permission denied")
    if p.exists() and not os.access(target, os.W_OK):
        raise ConfigError(f"cannot write {p}: permission denied")
    return p


def check_folder(path: Path | str, names: tuple[str, ...] = ()) -> Path:
    """Fail early when files named ``names`` cannot be written into folder ``path``.

    Creates the folder when it is missing.

    Raises:
        ConfigError: When ``path`` is a file, cannot be created or is not writable, or one of
            ``names`` inside it is a folder.
    """
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise ConfigError(f"cannot write into {p}: it is a file, not a folder")
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError(f"cannot create the folder {p}: {exc.strerror}") from exc
    if not os.access(p, os.W_OK | os.X_OK):
        raise ConfigError(f"cannot write into {p}: permission denied")
    for name in names:
        check_writable(p / name)
    return p


def _identity(path: Path) -> str:
    """A key under which two spellings of one file compare equal."""
    return os.path.normcase(os.path.realpath(path))


def check_distinct(
    outputs: Mapping[str, Path | None], inputs: Mapping[str, Path | None] | None = None
) -> None:
    """Refuse outputs that would overwrite each other or an input.

    Args:
        outputs: Label (for the message, e.g. ``"--report"``) -> output file path (None: unused).
        inputs: Label -> input file path that no output may replace.

    Raises:
        ConfigError: Naming the two clashing labels and the path.
    """
    seen: dict[str, str] = {}
    for label, path in (inputs or {}).items():
        if path is not None:
            seen.setdefault(_identity(path), label)
    for label, path in outputs.items():
        if path is None or is_stream(path):  # /dev/null twice is fine
            continue
        key = _identity(path)
        if key in seen:
            other = seen[key]
            raise ConfigError(f"{label} and {other} name the same file {path}: give another path")
        seen[key] = label


def _mode_for(target: Path) -> int:
    """The permission bits a new file at ``target`` gets: those of the file it replaces, or
    ``0o666`` less the umask."""
    try:
        return stat.S_IMODE(os.stat(target).st_mode)
    except OSError:
        return 0o666 & ~_umask()


def temp_beside(path: Path | str, suffix: str | None = None) -> Path:
    """A new, empty temporary file beside ``path`` (the target of a link at ``path``), to be
    moved into place by :func:`commit` or removed by :func:`discard`.

    Args:
        path: The destination.
        suffix: Suffix of the temporary name (default: the destination's, so tools that choose a
            format by the suffix see the right one).

    Raises:
        ConfigError: When the file cannot be made.
    """
    target = Path(os.path.realpath(path))
    sfx = target.suffix if suffix is None else suffix
    try:
        fd, name = tempfile.mkstemp(
            prefix=f".{target.name}.", suffix=f".tmp{sfx}", dir=target.parent
        )
    except OSError as exc:
        raise ConfigError(f"cannot write {path}: {exc.strerror}") from exc
    os.close(fd)
    return Path(name)


def commit(tmp: Path, path: Path | str) -> None:
    """Move the finished temporary file ``tmp`` into place at ``path`` (through a link), with
    the mode of the file it replaces or the umask's.

    Raises:
        ConfigError: When the move fails (``tmp`` is then removed).
    """
    target = Path(os.path.realpath(path))
    try:
        os.chmod(tmp, _mode_for(target))
        os.replace(tmp, target)
    except OSError as exc:
        discard(tmp)
        raise ConfigError(f"cannot write {path}: {exc.strerror}") from exc


def discard(tmp: Path) -> None:
    """Remove a temporary file that will not be committed (no error if it is gone)."""
    with contextlib.suppress(OSError):
        tmp.unlink(missing_ok=True)


@contextlib.contextmanager
def atomic_path(path: Path | str, suffix: str | None = None) -> Iterator[Path]:
    """A temporary path beside ``path``; the file written there replaces ``path`` on success.

    On an exception (an interrupt included) the temporary file is removed and ``path`` is left
    as it was. A symbolic link at ``path`` is written through: its target is replaced.

    Args:
        path: The destination (a regular file or a new one).
        suffix: Suffix of the temporary name (see :func:`temp_beside`).

    Yields:
        The temporary path to write.

    Raises:
        ConfigError: When the temporary file cannot be made or moved into place.
    """
    tmp = temp_beside(path, suffix)
    try:
        yield tmp
    except OSError as exc:
        discard(tmp)
        raise ConfigError(f"cannot write {path}: {exc.strerror}") from exc
    except BaseException:
        discard(tmp)
        raise
    commit(tmp, path)


def write_text_atomic(path: Path | str, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path``: atomically for a file, straight through for a
    character device or a FIFO.

    Raises:
        ConfigError: When the file cannot be written.
    """
    p = check_writable(path)
    if is_stream(p):
        try:
            with open(p, "w", encoding="utf-8") as fh:
                fh.write(text)
        except OSError as exc:
            raise ConfigError(f"cannot write {p}: {exc.strerror}") from exc
        return p
    with atomic_path(p) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return p


def write_bytes_atomic(path: Path | str, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically (see :func:`atomic_path`).

    Raises:
        ConfigError: When the file cannot be written (``path`` is a folder, its folder is
            missing, the disk is full, ...).
    """
    p = Path(path)
    if p.is_dir():
        raise ConfigError(f"cannot write {p}: it is a folder")
    if not p.parent.is_dir():
        raise ConfigError(f"cannot write {p}: the folder {p.parent} does not exist")
    with atomic_path(p) as tmp:
        tmp.write_bytes(data)
    return p


def report_json(payload: dict[str, Any]) -> str:
    """The text a report file holds: JSON with sorted keys, 2-space indent, a final newline."""
    return json.dumps(payload, indent=2, sort_keys=True, allow_nan=False) + "\n"


def write_json_atomic(path: Path | str, payload: dict[str, Any]) -> Path:
    """Write ``payload`` as JSON (:func:`report_json`) to ``path`` atomically (see
    :func:`write_text_atomic` for links, devices and file modes)."""
    return write_text_atomic(path, report_json(payload))
