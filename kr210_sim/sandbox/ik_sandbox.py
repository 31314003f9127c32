"""A user's IK function in a process of its own: a time limit per call, a memory limit, a scratch
folder, its output captured, and nothing left running afterwards.

:class:`IkSandbox` describes the process (:class:`~kr210_sim.sandbox.confine.Launch`: ``python -m
kr210_sim.sandbox.ik_child``, its environment, scratch folder, pipes and the user's files it reads)
and has a :class:`~kr210_sim.sandbox.confine.Confinement` start it
(:class:`~kr210_sim.sandbox.confine.Unconfined` by default). That process
(:mod:`kr210_sim.sandbox.ik_child`) sets its limits, imports the SPEC's module (with
:func:`~kr210_sim.sandbox.user_ik.load_ik`, so a bad SPEC gives the same one-line message) and then
answers ``solve(T, q_ref)`` calls sent over a pipe (:mod:`kr210_sim.sandbox.ik_wire`). The sandbox
is callable with the same contract, so ``UserIk(spec, sandbox)`` plans and checks like any user IK:
an answer is judged by our forward kinematics in *this* process, where the user's code cannot reach.

What the user's process gets:

* its own session and process group (a Ctrl-C at the terminal does not reach it; the group is
  killed with SIGKILL when the sandbox closes) and ``PR_SET_PDEATHSIG`` = SIGKILL, so it dies
  with the process that started it, even when that one is killed;
* ``RLIMIT_AS`` (``memory_mb``), ``RLIMIT_FSIZE`` (:data:`FILE_LIMIT_MB`), no core dumps;
* a scratch folder as its working folder, ``HOME`` and ``TMPDIR``; stdin from ``/dev/null``;
  ``PYTHONDONTWRITEBYTECODE`` (no ``__pycache__`` beside the user's file); one BLAS thread;
* a module SPEC (``my_ik:solve``) finds its module where this process finds it: the folder it
  was found in comes first on the process's ``sys.path``;
* with ``capture``, its stdout and stderr read into a bounded buffer (:class:`Captured`: the
  first and last :data:`KEPT_BYTES` / 2 bytes and the total count).

What a fault becomes: a call with no answer within ``call_timeout`` is an :class:`IkTimeout`
("no answer within 2 s"), a process that dies (a signal, ``os._exit``, ``sys.exit``, running out
of memory) an :class:`IkCrashed` with what killed it. An answer larger than a message may be
(:data:`~kr210_sim.sandbox.ik_wire.MAX_FRAME`) is an unusable answer that says so, not a fault.
With ``stop=False`` (``run``, ``ik-check``, ``evaluate --ik-timeout``) both faults are ordinary
exceptions raised by the call, so the pose is judged unusable (the cycle is ``ik_failed``), and
the next call starts a fresh process. With ``stop=True`` (``grade``) the first fault raises
:class:`SandboxStop` (a ``BaseException`` that the IK checks do not catch), which ends the
student's grading with verdict ``timeout``, ``crashed`` or ``error``.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import weakref
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NoReturn

import numpy as np
import numpy.typing as npt

from kr210_sim.errors import ConfigError, IkSpecError
from kr210_sim.exercise.form import is_ros_form, resolve_spec, seed_scratch
from kr210_sim.sandbox import ik_wire
from kr210_sim.sandbox.captured import KEPT_BYTES, Captured, drain  # noqa: F401 (re-exported)
from kr210_sim.sandbox.confine import Confinement, Launch, Unconfined
from kr210_sim.sandbox.held import HELD_SHARE, Meter, Sched
from kr210_sim.sandbox.ik_wire import Oversized, answer_of, oversized, receive, refusal, send, short
from kr210_sim.sandbox.user_ik import UserIk, spec_file, spec_files

FloatArray = npt.NDArray[np.float64]

#: Default memory limit of the user's process (RLIMIT_AS) [MB]. Python, NumPy and MuJoCo (which
#: the loader imports; without OpenGL, one BLAS thread) take 135 MB of address space with
#: examples/ik_dh.py loaded (VmPeak), so about 890 MB are left to the user's code.
DEFAULT_MEMORY_MB = 1024
#: The smallest ``memory_mb`` accepted [MB]: room for the interpreter's own imports.
MIN_MEMORY_MB = 256
#: Largest file the user's process may write (RLIMIT_FSIZE) [MB].
FILE_LIMIT_MB = 64
#: Most file descriptors the user's process may hold (RLIMIT_NOFILE).
OPEN_FILES = 256
#: Time the user's module has to import (bounded by ``deadline``) [s].
LOAD_TIMEOUT = 30.0
#: Most notes kept per sandbox (see :attr:`IkSandbox.notes`).
MAX_NOTES = 200
#: Time a ROS-form server's script has to reach ``rospy.spin()`` under ``--ik`` (its sympy
#: set-up can take minutes) [s].
ROS_LOAD_TIMEOUT = 600.0
#: The user's process: :func:`kr210_sim.sandbox.ik_child.serve`.
CHILD_MODULE = "kr210_sim.sandbox.ik_child"


class IkTimeout(Exception):  # named for the message: "raised IkTimeout: no answer within 2 s"
    """The user's function gave no answer within the time limit."""


class IkCrashed(Exception):
    """The user's process died during a call (a signal, ``os._exit``, ``sys.exit``, out of
    memory)."""


class SandboxStop(BaseException):  # not an error: a verdict, past the checks' except clauses
    """Grading of this student ends here (``stop=True``).

    Args:
        verdict: ``timeout``, ``crashed`` or ``error``.
        detail: One line: what happened.
    """

    def __init__(self, verdict: str, detail: str) -> None:
        super().__init__(f"{verdict}: {detail}")
        self.verdict = verdict
        self.detail = detail


@dataclass(frozen=True, slots=True)
class Limits:
    """What the user's process may use.

    Attributes:
        call_timeout: Time a call may take before it counts as hanging [s]; None: no limit.
        memory_mb: Address space of the process (RLIMIT_AS) [MB]; None: no limit.
        load_timeout: Time the import of the user's module may take [s].
        cpu_s: CPU time of the process (RLIMIT_CPU; each process it starts has as much) [s];
            None: no limit.
        open_files: File descriptors it may hold (RLIMIT_NOFILE).

    Raises:
        ConfigError: A time limit that is not > 0, or less memory than :data:`MIN_MEMORY_MB`.
    """

    call_timeout: float | None = 2.0
    memory_mb: int | None = DEFAULT_MEMORY_MB
    load_timeout: float = LOAD_TIMEOUT
    cpu_s: float | None = None
    open_files: int = OPEN_FILES

    def __post_init__(self) -> None:
        if self.call_timeout is not None and not self.call_timeout > 0:
            raise ConfigError(f"call_timeout must be > 0 s, got {self.call_timeout}")
        if self.cpu_s is not None and not self.cpu_s > 0:
            raise ConfigError(f"cpu_s must be > 0 s, got {self.cpu_s}")
        if self.open_files < 32:
            raise ConfigError(f"open_files must be at least 32, got {self.open_files}")
        if self.memory_mb is not None and self.memory_mb < MIN_MEMORY_MB:
            raise ConfigError(f"memory_mb must be at least {MIN_MEMORY_MB}, got {self.memory_mb}")


def _grader_module(spec: str) -> bool:
    """Whether ``spec`` names a module of kr210_sim itself (not a file)."""
    where = spec.rpartition(":")[0]
    if where.endswith(".py") or "/" in where or os.sep in where:
        return False
    return where.partition(".")[0] == __name__.partition(".")[0]


def _seconds(s: float) -> str:
    return f"{s:g} s"


def _how_it_ended(code: int | None) -> str:
    if code is None:
        return "stopped answering"
    if code < 0:
        try:
            name = signal.Signals(-code).name
        except ValueError:
            name = f"signal {-code}"
        return f"was killed by {name}"
    return f"exited with code {code}"


class IkSandbox:
    """A user's IK function running in a process of its own (see the module doc).

    Args:
        spec: The SPEC (``path/to/file.py:function`` or ``package.module:function``).
        limits: Time and memory limits.
        scratch: The process's working folder (made if missing, kept); None: a temporary folder,
            removed on :meth:`close`.
        capture: Keep the process's stdout and stderr (:attr:`stdout`, :attr:`stderr`) instead
            of letting it write to ours.
        stop: Raise :class:`SandboxStop` at the first fault instead of an exception per call
            (and a fresh process for the next call).
        deadline: ``time.monotonic()`` after which any wait counts as a timeout (the whole
            student's limit), or None. A wait for the process's answer is moved on by the time
            others held it off the CPU (:mod:`~kr210_sim.sandbox.held`): by at most
            :data:`~kr210_sim.sandbox.held.HELD_SHARE` of its time limit per call, and in all by
            at most :attr:`held_room` against the deadline.
        confinement: What starts and ends the process (:class:`~kr210_sim.sandbox.confine.
            Unconfined` when None).
        root: The user's own files the process reads (a student's submission: a file or a
            folder); None: the SPEC's (:func:`~kr210_sim.sandbox.user_ik.spec_files`).
    """

    #: The module the user's process runs, and what messages call that process.
    child, what = CHILD_MODULE, "IK"

    def __init__(
        self,
        spec: str,
        limits: Limits | None = None,
        scratch: Path | None = None,
        capture: bool = False,
        stop: bool = False,
        deadline: float | None = None,
        confinement: Confinement | None = None,
        root: Path | None = None,
    ) -> None:
        self.spec = spec = resolve_spec(spec)
        source = spec_file(spec)
        #: A ROS-form server (:mod:`kr210_sim.exercise`): it takes batches, and the files
        #: beside it are copied into its working folder.
        self.ros = source is not None and is_ros_form(source)
        self.confinement: Confinement = confinement or Unconfined()
        files = spec_files(spec)
        self.readable = (root.resolve(),) if root is not None else files.readable
        self._root = root
        self._search = files.search
        self.limits = limits or Limits()
        self.capture = capture
        self.stop = stop
        self.deadline = deadline
        #: How long the waits may still be moved on past :attr:`deadline` for the time the
        #: process was held off the CPU [s] (its owner's: a graded student's clock sets it).
        self.held_room = 0.0
        #: Time the last wait (the import, or a call) was held off the CPU by others [s].
        self.held = 0.0
        self.stdout = Captured()
        self.stderr = Captured()
        self.starts = 0
        self.calls = 0
        #: Poses asked for, in all (a batch asks for many in one call).
        self.poses = 0
        self.faults: list[str] = []
        #: What Python 2 semantics changed in a ROS-form server's code (its notes, in order).
        self.notes: list[str] = []
        #: The grader's own modules the user's code tried to import in its jail, refused
        #: (:class:`~kr210_sim.sandbox.harness.Guard`), each once, in order.
        self.blocked: list[str] = []
        #: The SPEC names a module of kr210_sim itself: its jail holds the whole package.
        self.grader_code = _grader_module(spec)
        self._own_scratch = scratch is None
        self.scratch = Path(tempfile.mkdtemp(prefix="kr210_ik_")) if scratch is None else scratch
        self.scratch.mkdir(parents=True, exist_ok=True)
        self._proc: subprocess.Popen[bytes] | None = None
        self._fds: tuple[int, int] = (-1, -1)
        self._threads: list[threading.Thread] = []
        self._finalizer = weakref.finalize(self, IkSandbox._cleanup, {}, self.confinement)
        # A scratch folder made here goes with the sandbox: on close, collection or exit.
        self._remove_scratch = weakref.finalize(self, shutil.rmtree, self.scratch, True)
        if not self._own_scratch:
            self._remove_scratch.detach()  # the caller's folder stays

    # ------------------------------------------------------------------ process
    def _environment(self) -> dict[str, str]:
        env = dict(os.environ)
        scratch = str(self.scratch.resolve())
        env.update(
            HOME=scratch,
            TMPDIR=scratch,
            PYTHONDONTWRITEBYTECODE="1",
            PYTHONUNBUFFERED="1",
            OMP_NUM_THREADS="1",
            OPENBLAS_NUM_THREADS="1",
            MKL_NUM_THREADS="1",
            MUJOCO_GL="disable",
        )
        root = str(Path(__file__).resolve().parents[2])  # this kr210_sim's folder, first
        paths = (root, *map(str, self._search), env.get("PYTHONPATH", ""))
        env["PYTHONPATH"] = os.pathsep.join(p for p in paths if p)
        return env

    def launch(self, req_r: int, ans_w: int) -> Launch:
        """The user's process as it is to be started, with the pipe ends it keeps."""
        limits: dict[str, Any] = {
            "memory_mb": self.limits.memory_mb,
            "file_mb": FILE_LIMIT_MB,
            "cpu_s": self.limits.cpu_s,
            "open_files": self.limits.open_files,
            "processes": self.confinement.process_rlimit,
            "harness": self._harness_only(),
        }
        parent = 0 if self.confinement.own_pids else os.getpid()
        argv: tuple[str, ...] = (sys.executable, "-B", "-m", self.child, self._child_spec())
        argv += (str(req_r), str(ans_w), str(parent), json.dumps(limits))
        return Launch(
            argv=argv,
            env=self._environment(),
            scratch=self.scratch.resolve(),
            pass_fds=(req_r, ans_w),
            readable=self.readable,
            capture=self.capture,
            grader_code=self.grader_code,
        )

    def _harness_only(self) -> bool:
        """Whether the user's process holds only kr210_sim's harness (and must refuse and
        report imports of the rest)."""
        return bool(getattr(self.confinement, "harness_only", False)) and not self.grader_code

    def _keep_blocked(self, message: dict[str, Any]) -> None:
        """Keep the names of the grader's modules a message says were refused."""
        names = message.get("blocked")
        if not isinstance(names, list):
            return
        for name in names[:MAX_NOTES]:
            text = short(str(name), 200)
            if text not in self.blocked and len(self.blocked) < MAX_NOTES:
                self.blocked.append(text)

    def start(self) -> None:
        """Start the process and import the user's module.

        Raises:
            IkSpecError: The module cannot be imported (the loader's one line), or the import
                took longer than ``load_timeout`` (``stop=False``).
            SandboxStop: The same with ``stop=True`` (``error``, ``timeout`` or ``crashed``).
        """
        self.close_process()
        if self.ros:  # as under rosrun, the files beside the script are in its working folder
            seed_scratch(Path(self.spec.rpartition(":")[0]), self.scratch, self._root)
        limit = self.limits.load_timeout
        meter = self._meter(limit, new=True)
        req_r, req_w = os.pipe()
        ans_r, ans_w = os.pipe()
        try:
            proc = self.confinement.popen(self.launch(req_r, ans_w))
        except BaseException:
            os.close(req_w)
            os.close(ans_r)
            raise
        finally:
            os.close(req_r)
            os.close(ans_w)
        self._proc, self._fds = proc, (req_w, ans_r)
        self.starts += 1
        self._finalizer.detach()
        self._finalizer = weakref.finalize(
            self, IkSandbox._cleanup, {"proc": proc, "fds": self._fds}, self.confinement
        )
        if self.capture:
            assert proc.stdout is not None and proc.stderr is not None
            for stream, sink in ((proc.stdout, self.stdout), (proc.stderr, self.stderr)):
                t = threading.Thread(target=drain, args=(stream, sink), daemon=True)
                t.start()
                self._threads.append(t)
        try:
            got = receive(ans_r, meter.ready(ans_r, self._until(limit, meter.start)))
        except TimeoutError:
            took = _seconds(self._limit(limit, meter.start))
            self._fault("timeout", f"importing it took longer than {took}")
        finally:
            self.held = meter.look()
        if isinstance(got, ik_wire.Malformed):
            self._forged(got, "while importing it")
        message = got if isinstance(got, dict) else None
        if message is not None:
            self._keep_blocked(message)
        if message is not None and message.get("ready"):
            self._asked(False)  # between calls, its CPU is what nobody else wants
            return
        if message is not None and "error" in message:
            self.close_process()
            text = str(message["error"]).replace(self._child_spec(), self.spec)
            where = self.spec.rpartition(":")[0]
            text = text.replace(str(Path(where).resolve()), where)
            if self.stop:
                raise SandboxStop("error", text)
            raise IkSpecError(text)
        self._died("while importing it", message)

    def _child_spec(self) -> str:
        """The SPEC as the user's process (in the scratch folder) must see it: a file's path made
        absolute."""
        where, _, name = self.spec.rpartition(":")
        if where.endswith(".py") or "/" in where or os.sep in where:
            return f"{Path(where).resolve()}:{name}"
        return self.spec

    def _limit(self, limit: float | None, since: float | None = None) -> float:
        """The wait for ``limit`` [s] cut to what is left before the deadline (at ``since``,
        ``time.monotonic()``; None: now)."""
        if self.deadline is None:
            return math.inf if limit is None else limit
        left = max(0.0, self.deadline - (time.monotonic() if since is None else since))
        return left if limit is None else min(limit, left)

    def _until(self, limit: float | None, since: float | None = None) -> float | None:
        now = time.monotonic() if since is None else since
        wait = self._limit(limit, now)
        return None if math.isinf(wait) else now + wait

    def _meter(self, limit: float | None, new: bool = False) -> Meter:
        """The time held off the CPU during a wait of ``limit`` [s] (see ``deadline``)."""
        caps = [HELD_SHARE * limit] if limit is not None else []
        caps += [self.held_room] if self.deadline is not None else []
        return Meter(self._sched, min(caps, default=0.0), new)

    def _sched(self, fresh: bool) -> Sched | None:
        sched = getattr(self.confinement, "sched", None)
        proc = self._proc
        return None if sched is None or proc is None else sched(proc, fresh)

    def _fault(self, verdict: str, detail: str) -> NoReturn:
        """Kill the process and raise the fault (``stop``: SandboxStop)."""
        self.close_process()
        self.faults.append(detail)
        if self.stop:
            if verdict == "timeout" and self.deadline is not None:
                if time.monotonic() >= self.deadline - 1e-3:
                    detail = "the time limit for the whole student ran out"
            raise SandboxStop(verdict, detail)
        if verdict == "timeout":
            raise IkTimeout(detail)
        raise IkCrashed(detail)

    def _forged(self, got: ik_wire.Malformed, when: str) -> NoReturn:
        """The user's code wrote to the answer pipe itself, ``when``: a fault, said so."""
        self._fault(
            "crashed",
            f"wrote {got.size:,} bytes to the grader's answer pipe itself {when}, not a message "
            f"of the harness's ({got.why})",
        )

    def _died(self, when: str, message: dict[str, Any] | None) -> NoReturn:
        proc = self._proc
        code = None
        if proc is not None:
            with contextlib.suppress(subprocess.TimeoutExpired):
                code = self.confinement.returncode(proc.wait(timeout=2.0))
        if message is not None and "exit" in message:
            what = f"called sys.exit({message['exit']!r}) {when}"
        elif message is not None and message.get("memory"):
            what = f"ran out of memory {when} (limit {self.limits.memory_mb} MB)"
        else:
            what = f"the {self.what} process {_how_it_ended(code)} {when}"
            if code == -signal.SIGXCPU:
                what += f" (its CPU time ran out: limit {self.limits.cpu_s:g} s)"
            elif code == -signal.SIGKILL:
                cpu = " or past its CPU time limit" if self.limits.cpu_s is not None else ""
                what += f" (out of memory{cpu}?)"
        self._fault("crashed", what)

    # ------------------------------------------------------------------ calls
    def _send(self, fd: int, message: dict[str, Any], until: float | None) -> None:
        """Write a request (a subclass may follow it with raw bytes)."""
        send(fd, message, until)

    def _request(self, message: dict[str, Any], limit: float | None) -> dict[str, Any] | Oversized:
        """Send one request (numbered) and wait ``limit`` [s] for its answer; a fault raises
        (:meth:`_fault`, :meth:`_died`)."""
        if self._proc is None or self._proc.poll() is not None:
            self.start()
        self.calls += 1
        meter = self._meter(limit)
        until = self._until(limit, meter.start)  # its writing counts: it may stop reading
        self._asked(True)
        try:
            return self._exchange(message, until, limit, meter)
        finally:
            self.held = meter.look()
            self._asked(False)

    def _asked(self, busy: bool) -> None:
        """Tell the confinement whether an answer is awaited (its CPU weight follows)."""
        asked = getattr(self.confinement, "asked", None)
        if asked is not None and self._proc is not None:
            asked(self._proc, busy)

    def _exchange(
        self, message: dict[str, Any], until: float | None, limit: float | None, meter: Meter
    ) -> dict[str, Any] | Oversized:
        """Send the request and read its answer (see :meth:`_request`)."""
        req_w, ans_r = self._fds
        try:
            self._send(req_w, {"n": self.calls, **message}, until)
        except TimeoutError:
            self._fault(
                "timeout", f"did not read its request within {_seconds(self._limit(limit))}"
            )
        except OSError:
            self._died("before a call", None)
        while True:
            try:
                until = meter.ready(ans_r, until)
                got = receive(ans_r, until)
            except TimeoutError:
                took = _seconds(self._limit(limit, meter.start))
                self._fault("timeout", f"no answer within {took}")
            if isinstance(got, Oversized):
                return got
            if isinstance(got, ik_wire.Malformed):
                self._forged(got, "during a call")
            if got is None or "exit" in got or got.get("memory"):
                self._died("during a call", got)
            if got.get("n") == self.calls:
                self._keep_blocked(got)
                notes = got.get("notes")
                if isinstance(notes, list) and len(self.notes) < MAX_NOTES:
                    self.notes += [short(str(n), 400) for n in notes[:MAX_NOTES]]
                return got
            # else: a message of an earlier call's (the user's code wrote one of its own to the
            # pipe before its answer): dropped, as the deadline still runs

    def __call__(self, T: FloatArray, q_ref: FloatArray) -> Any:
        """``solve(T, q_ref)`` in the user's process: the answer as it came (six numbers as an
        array, None, or the exception it raised, re-raised here with its type's name)."""
        self.poses += 1
        T_list = np.asarray(T, dtype=np.float64).reshape(16).tolist()
        q_list = np.asarray(q_ref, dtype=np.float64).reshape(-1).tolist()
        got = self._request({"T": T_list, "q": q_list}, self._pose_limit(1))
        if isinstance(got, Oversized):
            return oversized(got.size)
        return answer_of(got)

    def _pose_limit(self, n: int) -> float | None:
        """How long a request of ``n`` poses may take [s]: ``call_timeout`` per pose, or for a
        ROS-form server within a time budget (a graded student's :attr:`deadline`) what is left
        of it: its sympy costs up to ~1.6 s a pose on an idle machine (and a request's set-up,
        a symbolic inverse, seconds), more under load and its jail's one-core quota, so the
        limit per pose would time out a server that is only slow; the budget still ends one that
        never answers."""
        if self.ros and self.deadline is not None:
            return None
        return None if self.limits.call_timeout is None else self.limits.call_timeout * n

    def batch(self, poses: Sequence[FloatArray], q_refs: Sequence[FloatArray] = ()) -> list[Any]:
        """Many poses in one call (a ROS-form server gets them as one request, as MoveIt sent
        a planned path): one answer per pose, as :meth:`__call__` gives it, but an exception
        the user's code raised on a pose is that pose's answer, not raised. The call may take
        ``call_timeout`` per pose, or for a ROS-form server with a :attr:`deadline` (a graded
        student's budget) up to the deadline.

        Args:
            poses: The poses (4x4).
            q_refs: The joint state sent with each (zeros when not given; a ROS-form server
                does not see it).
        """
        n = len(poses)
        self.poses += n
        qs = list(q_refs) or [np.zeros(6)] * n
        message = {
            "batch": [np.asarray(T, dtype=np.float64).reshape(16).tolist() for T in poses],
            "q": [np.asarray(q, dtype=np.float64).reshape(-1).tolist() for q in qs],
        }
        got = self._request(message, self._pose_limit(n))
        if isinstance(got, Oversized):
            return [oversized(got.size)] * n
        entries = got.get("answers")
        if not isinstance(entries, list) or len(entries) != n:
            return [refusal("a malformed answer", f"the answers to {n} poses did not come")] * n
        out: list[Any] = []
        for e in entries:
            try:
                out.append(
                    answer_of(e) if isinstance(e, dict) else refusal("a malformed answer", "")
                )
            except Exception as exc:  # the exception the user's code raised on this pose
                out.append(exc)
        return out

    def user_ik(self) -> UserIk:
        """This sandbox as a :class:`~kr210_sim.sandbox.user_ik.UserIk`: its SPEC, calls, and
        for a ROS-form server its batches."""
        return UserIk(self.spec, self, batch=self.batch if self.ros else None)

    # ------------------------------------------------------------------ ending
    @staticmethod
    def _cleanup(state: dict[str, Any], confinement: Confinement) -> None:
        proc: subprocess.Popen[bytes] | None = state.get("proc")
        if proc is not None:  # first, while the process still waits on its pipe: the
            confinement.end(proc)  # confinement sees what it left running, not its exit
        for fd in state.get("fds", ()):
            with contextlib.suppress(OSError):
                os.close(fd)

    def close_process(self) -> None:
        """Kill the user's process group (if running) and collect its output threads."""
        if self._proc is None:
            return
        self._finalizer.detach()
        IkSandbox._cleanup({"proc": self._proc, "fds": self._fds}, self.confinement)
        self._proc, self._fds = None, (-1, -1)
        for t in self._threads:
            t.join(timeout=5.0)
        self._threads.clear()

    def close(self) -> None:
        """Kill the process and remove the scratch folder when it was made here."""
        self.close_process()
        self._remove_scratch()

    def __enter__(self) -> IkSandbox:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
