"""Input files: regular files of bounded size, refused in one line before anything blocks.

Opening a FIFO for reading waits for a writer, forever when none comes, and a character device
(``/dev/zero``) never ends: every file a command reads (a cell file, a scene, a recording, an
episodes file) is checked here first.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from kr210_sim.errors import ConfigError


def check_regular(path: Path | str, what: str) -> Path:
    """``path`` as a :class:`Path` when it is a regular file (through symbolic links).

    Args:
        path: The file to be read.
        what: What it is, for the message ("cell file", "scene", ...).

    Raises:
        ConfigError: When it is missing, a folder, a FIFO, a device or a socket (one line).
    """
    p = Path(path)
    try:
        mode = os.stat(p).st_mode
    except FileNotFoundError:
        raise ConfigError(f"{what} not found: {p}") from None
    except OSError as exc:
        raise ConfigError(f"cannot read {what} {p}: {exc.strerror}") from exc
    if stat.S_ISDIR(mode):
        raise ConfigError(f"{what} {p} is a folder: give a file")
    if not stat.S_ISREG(mode):
        kind = "a FIFO" if stat.S_ISFIFO(mode) else "a device or a socket"
        raise ConfigError(f"{what} {p} is {kind}, not a regular file: give a file")
    return p


def read_input(path: Path | str, what: str, max_bytes: int) -> bytes:
    """The bytes of the regular file ``path``, at most ``max_bytes`` of them.

    Raises:
        ConfigError: When the file is not a regular file (:func:`check_regular`), cannot be
            read, or is larger than ``max_bytes``.
    """
    p = check_regular(path, what)
    try:
        with open(p, "rb") as fh:
            data = fh.read(max_bytes + 1)
    except OSError as exc:
        raise ConfigError(f"cannot read {what} {p}: {exc.strerror}") from exc
    if len(data) > max_bytes:
        raise ConfigError(f"{what} {p} is larger than {max_bytes:,} bytes: not a {what}")
    return data
