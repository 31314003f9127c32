"""How a user's IK process is started and ended: what it runs, what it may see, who ends it.

:class:`~kr210_sim.sandbox.ik_sandbox.IkSandbox` describes the process it wants as a
:class:`Launch` (the command, its environment, its scratch folder, the pipes it keeps, the user's
own files it must read) and hands it to a :class:`Confinement`, which starts it and, at the end,
makes sure nothing it started is left. :class:`Unconfined` is the plain way: a session and process
group of its own, killed whole at the end; the user's code runs as the caller and sees what the
caller sees. A jail that confines it further implements the same two calls.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

from kr210_sim.sandbox import held, procfs
from kr210_sim.sandbox.held import Sched


@dataclass(frozen=True, slots=True)
class Launch:
    """The user's process as the sandbox wants it.

    Attributes:
        argv: The command (an interpreter running :mod:`kr210_sim.sandbox.ik_child`).
        env: Its whole environment.
        scratch: Its working folder, ``HOME`` and ``TMPDIR``: the one folder it may write.
        pass_fds: File descriptors it keeps (the two ends of its pipes).
        readable: The user's own files and folders it must be able to read (the SPEC's file or
            folder, a module's file or package): in a jail, the only ones of the user's.
        capture: Its stdout and stderr go to pipes (read by the sandbox) rather than to ours.
        grader_code: The SPEC names a module of kr210_sim itself (``--ik
            kr210_sim.robot.kinematics:nearest``, chosen by whoever runs the grader): a jail
            then holds the whole package, not only its harness
            (:mod:`kr210_sim.sandbox.harness`).
    """

    argv: tuple[str, ...]
    env: dict[str, str]
    scratch: Path
    pass_fds: tuple[int, ...]
    readable: tuple[Path, ...]
    capture: bool
    grader_code: bool = False


class Confinement(Protocol):
    """Starts a :class:`Launch` and ends all it started."""

    @property
    def name(self) -> str:
        """What reports call it (``none``, or the jail's name)."""
        ...

    def popen(self, launch: Launch) -> subprocess.Popen[bytes]:
        """Start the process. Its stdin is ``/dev/null``; with ``capture`` its stdout and stderr
        are pipes."""
        ...

    def end(self, proc: subprocess.Popen[bytes]) -> None:
        """Kill ``proc`` and everything it started (SIGKILL) and wait for it; release what
        :meth:`popen` made for it. Safe to call twice and on a process that has ended."""
        ...

    def asked(self, proc: subprocess.Popen[bytes], busy: bool) -> None:
        """Whether an answer of ``proc``'s is awaited now (``busy``): a confinement may let it
        have CPU only then, beside its neighbours."""
        ...

    def sched(self, proc: subprocess.Popen[bytes], fresh: bool) -> Sched | None:
        """What the kernel says of the CPU of ``proc`` and the processes it started
        (:func:`~kr210_sim.sandbox.held.read`), to tell the time others held it off the CPU;
        ``fresh``: look for its processes again, else those found last may do. None: nothing
        to read (it has ended)."""
        ...

    def describe(self) -> dict[str, Any]:
        """What protects the user's process, for reports (``{"confinement": name, ...}``)."""
        ...

    @property
    def own_pids(self) -> bool:
        """The user's process sees pids of its own (a PID namespace): the parent's pid it is
        given must be 0 ("do not compare")."""
        ...

    @property
    def process_rlimit(self) -> int | None:
        """``RLIMIT_NPROC`` the user's process must set itself, or None."""
        ...

    @property
    def harness_only(self) -> bool:
        """Only kr210_sim's harness is importable by the user's process
        (:mod:`kr210_sim.sandbox.harness`): it must refuse and report the rest."""
        ...

    def returncode(self, code: int | None) -> int | None:
        """The user's process's exit (``Popen.returncode`` form: -N for signal N) from what the
        started process's ``returncode`` is (a wrapper may encode it)."""
        ...

    def findings(self) -> list[str]:
        """What it stopped so far, one line each, as the kernel saw it (none here)."""
        ...


def popen(launch: Launch, argv: tuple[str, ...] | None = None) -> subprocess.Popen[bytes]:
    """``launch`` started in a session and process group of its own (``argv`` in place of its
    command, for a confinement that wraps it)."""
    out = subprocess.PIPE if launch.capture else None
    return subprocess.Popen(
        list(argv or launch.argv),
        stdin=subprocess.DEVNULL,
        stdout=out,
        stderr=out,
        pass_fds=launch.pass_fds,
        cwd=launch.scratch,
        env=launch.env,
        start_new_session=True,
    )


def kill_group(proc: subprocess.Popen[bytes], wait: float = 5.0) -> None:
    """SIGKILL ``proc``'s process group (its pid: it leads a session of its own) and reap it."""
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(proc.pid, signal.SIGKILL)
    with contextlib.suppress(subprocess.TimeoutExpired):
        proc.wait(timeout=wait)


class Unconfined:
    """No jail: the user's process runs as the caller, in a session and process group of its own
    (a Ctrl-C at the terminal does not reach it), killed whole at the end. A process that leaves
    that group (``setsid``) is not killed with it."""

    name = "none"
    own_pids = False
    process_rlimit = None
    harness_only = False

    def popen(self, launch: Launch) -> subprocess.Popen[bytes]:
        """Start ``launch`` in a session of its own."""
        return popen(launch)

    def end(self, proc: subprocess.Popen[bytes]) -> None:
        """Kill its process group and reap it."""
        self.__dict__.get("_trees", {}).pop(proc.pid, None)
        kill_group(proc)

    def asked(self, proc: subprocess.Popen[bytes], busy: bool) -> None:
        """Nothing: it weighs as any process of the caller's."""

    def sched(self, proc: subprocess.Popen[bytes], fresh: bool) -> Sched | None:
        """The CPU of ``proc`` and the processes below it (a scan of ``/proc`` when ``fresh``,
        else those found at the last scan)."""
        if proc.poll() is not None:
            return None
        trees: dict[int, list[int]] = self.__dict__.setdefault("_trees", {})
        if fresh or proc.pid not in trees:
            trees[proc.pid] = [proc.pid, *procfs.descendants(proc.pid)]
        return held.read(trees[proc.pid], states=fresh)

    def describe(self) -> dict[str, Any]:
        """``{"confinement": "none"}``."""
        return {"confinement": self.name}

    @staticmethod
    def returncode(code: int | None) -> int | None:
        """``code`` as it is."""
        return code

    def findings(self) -> list[str]:
        """Nothing: no jail, no findings."""
        return []
