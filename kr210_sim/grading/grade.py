"""``grade``: many students' IK solutions, each in its own sandbox, one leaderboard.

Who the students are: :mod:`kr210_sim.grading.roster`. Each student is graded by a process of its
own, its *grading process* (:mod:`kr210_sim.grading.student`), at most ``workers`` at a time; that
process runs the student's IK in a sandbox (:mod:`kr210_sim.sandbox.ik_sandbox`). Every grading
process is started in a session of its own and dies with its parent (``PR_SET_PDEATHSIG``).

What comes back, and what is believed: the grading process gets its job and a fresh key on its
standard input and sends its record over a pipe that only it and the grader hold, sealed with
that key (:mod:`kr210_sim.grading.record`). The record counts only when that process exited with
code 0 and the record is one sealed frame with every field the leaderboard reads; otherwise
the student is ``crashed``, with a detail that says which (and, for a process that died, the
line of its standard error that tells why: the last line of a traceback). A student's record
can never stop the report: whatever is wrong with it is that student's verdict.

Time: ``timeout`` bounds the student's own time (importing its module, and each call from the
pose sent to the answer back, less the time other processes held it off the CPU:
:class:`~kr210_sim.grading.clock.StudentClock`), which may take at most
:data:`~kr210_sim.sandbox.held.HELD_SHARE` more of wall time; our own part of a student
(start-up, checks, planning, simulation) has a cap of its own,
:attr:`GradeSettings.own_time_cap`. A grading process still running after both is killed, and
the student is ``timeout`` with a detail that says so.

The scratch folders (one per student, named by its index, the student's working folder) and the
plots live in one temporary folder that is removed at the end. On Ctrl-C or SIGTERM the running
students are killed, the report of the students finished so far is written (whole, however
many signals follow: :func:`~kr210_sim.util.interrupts.winding_up`), and the exit code says
which signal it was; a signal during the command's start-up gives a report of no students.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import re
import secrets
import selectors
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

from kr210_sim.errors import ConfigError
from kr210_sim.grading.ikcheck import MAX_RANDOM_CASES
from kr210_sim.grading.leaderboard import build_report, student_line, table, write_html
from kr210_sim.grading.record import (
    RECORD_LIMIT,
    blank_record,
    clean,
    one_line,
    printable,
    record_problem,
    unseal,
)
from kr210_sim.grading.roster import STUDENT_FUNCTION, STUDENT_MODULE, Student, find_students
from kr210_sim.grading.student import STUDENT_COMMAND, StudentJob
from kr210_sim.sandbox.held import HELD_SHARE
from kr210_sim.sandbox.ik_sandbox import DEFAULT_MEMORY_MB, MIN_MEMORY_MB
from kr210_sim.sandbox.jail import Jail, unjailed, unjailed_warning
from kr210_sim.sandbox.user_ik import spec_file
from kr210_sim.sim.runner import MAX_CYCLES
from kr210_sim.util.interrupts import end_start_up, signal_name, winding_up
from kr210_sim.util.outputs import check_distinct, check_writable, write_json_atomic

__all__ = [
    "STUDENT_FUNCTION",
    "STUDENT_MODULE",
    "GradeResult",
    "GradeSettings",
    "Student",
    "find_students",
    "grade",
]

#: Our own part of a student, at most: a base [s] ...
OWN_TIME_BASE = 120.0
#: ... plus this per cycle of the run [s] ...
OWN_TIME_PER_CYCLE = 30.0
#: ... plus this per random ik-check case [s].
OWN_TIME_PER_CASE = 0.01
#: How often the grader looks at its running students [s].
POLL = 0.05
#: Bytes of a grading process's standard error kept (the last ones).
STDERR_KEPT = 16_384
#: How long the grader waits for a grading process's pipes to close once it exited [s].
EOF_GRACE = 2.0
#: A Python warning line (``file:line: SomeWarning: text``): never the reason a process died.
_WARNING = re.compile(r"^\S.*:\d+: \w*Warning: ")


@dataclass(frozen=True, slots=True)
class GradeSettings:
    """How every student is graded.

    Attributes:
        cases: Random ik-check poses on top of the fixed set (0 to 1,000,000).
        cycles: Cycles of the run (1 to 10,000).
        seed: Seed of the random poses and of the run.
        timeout: The student's own time, in all [s] (see the module doc).
        ik_timeout: Time per IK call [s].
        memory_mb: Memory limit of each student's process [MB].
        workers: Students graded at once.
        min_success: The run's pass bar (share of ``cycles``).
        jail: Each student's IK in a bubblewrap jail (:mod:`kr210_sim.sandbox.jail`); False:
            ``--no-jail``.

    Raises:
        ConfigError: A value out of its range (one line naming the option).
    """

    cases: int = 1000
    cycles: int = 10
    seed: int = 0
    timeout: float = 120.0
    ik_timeout: float = 2.0
    memory_mb: int = DEFAULT_MEMORY_MB
    workers: int = 1
    min_success: float = 0.8
    jail: bool = True

    def __post_init__(self) -> None:
        def whole(v: object) -> bool:
            return isinstance(v, int) and not isinstance(v, bool)

        if not (whole(self.cases) and 0 <= self.cases <= MAX_RANDOM_CASES):
            raise ConfigError(
                f"--cases must be a whole number from 0 to {MAX_RANDOM_CASES:,}, got {self.cases}"
            )
        if not (whole(self.cycles) and 1 <= self.cycles <= MAX_CYCLES):
            raise ConfigError(
                f"--cycles must be a whole number from 1 to {MAX_CYCLES:,}, got {self.cycles}"
            )
        if not (whole(self.seed) and self.seed >= 0):
            raise ConfigError(f"--seed must be a whole number >= 0, got {self.seed}")
        if not (whole(self.memory_mb) and self.memory_mb >= MIN_MEMORY_MB):
            raise ConfigError(f"--memory must be at least {MIN_MEMORY_MB} MB, got {self.memory_mb}")
        for value in (self.timeout, self.ik_timeout):
            if not (isinstance(value, int | float) and 0 < value < math.inf):
                raise ConfigError("--timeout and --ik-timeout must be > 0 s")
        if not (whole(self.workers) and self.workers >= 1):
            raise ConfigError(f"--workers must be at least 1, got {self.workers}")
        if not (isinstance(self.min_success, int | float) and 0 <= self.min_success <= 1):
            raise ConfigError(f"--min-success must be in [0, 1], got {self.min_success}")

    @property
    def own_time_cap(self) -> float:
        """Time our own part of a student may take [s]: :data:`OWN_TIME_BASE` plus
        :data:`OWN_TIME_PER_CYCLE` per cycle and :data:`OWN_TIME_PER_CASE` per random case
        (430 s at the defaults, some 20 times what a correct student takes beside another)."""
        return OWN_TIME_BASE + OWN_TIME_PER_CYCLE * self.cycles + OWN_TIME_PER_CASE * self.cases

    def config(self) -> dict[str, Any]:
        """The report's ``config``: what every student is graded with."""
        return {
            "cases": self.cases,
            "cycles": self.cycles,
            "seed": self.seed,
            "timeout_s": self.timeout,
            "ik_timeout_s": self.ik_timeout,
            "own_time_cap_s": self.own_time_cap,
            "memory_mb": self.memory_mb,
            "min_success": self.min_success,
            "jail": self.jail,
        }


@dataclass
class GradeResult:
    """What ``grade`` produced.

    Attributes:
        report: The JSON-ready report (students sorted as the leaderboard).
        text: The leaderboard table.
        interrupted: The interrupt that stopped the grading, or None.
        html_path: The page written (None without ``--html``).
        records: The students' records, in the order they finished (with ``plots``).
    """

    report: dict[str, Any]
    text: str
    interrupted: KeyboardInterrupt | None = None
    html_path: Path | None = None
    records: list[dict[str, Any]] = field(default_factory=list)

    @property
    def all_passed(self) -> bool:
        """Every student passed (and the grading was not interrupted)."""
        return self.interrupted is None and all(r["verdict"] == "pass" for r in self.records)


def _ended(code: int) -> str:
    if code < 0:
        try:
            return f"was killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"was killed by signal {-code}"
    return f"exited with code {code}"


def relevant_line(stderr: bytes) -> str:
    """The line of a dead process's standard error that tells why it died: the last line of
    its last traceback, else its last line that is not a Python warning ("" when none)."""
    lines = [ln.strip() for ln in stderr.decode("utf-8", "replace").splitlines()]
    starts = [i for i, ln in enumerate(lines) if ln.startswith("Traceback (most recent call")]
    if starts:
        lines = lines[starts[-1] :]
    else:
        lines = [ln for ln in lines if not _WARNING.match(ln)]
    lines = [ln for ln in lines if ln]
    return one_line(printable(lines[-1])) if lines else ""


@dataclass(eq=False)
class _Running:
    """One grading process and what it sent so far."""

    index: int
    student: Student
    proc: subprocess.Popen[bytes]
    key: bytes
    started: float
    record: bytearray = field(default_factory=bytearray)
    stderr: bytearray = field(default_factory=bytearray)
    fds: list[int] = field(default_factory=list)
    ended: float | None = None
    too_big: bool = False


def _kill(proc: subprocess.Popen[bytes]) -> None:
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(proc.pid, signal.SIGKILL)
    with contextlib.suppress(subprocess.TimeoutExpired):
        proc.wait(timeout=10.0)


class _Pool:
    """The grading processes running now: started, read and ended here.

    Args:
        settings: How every student is graded.
        root: The temporary folder (scratch folders and plots).
        plots: Whether the grading processes make the error plots (for the page).
    """

    def __init__(self, settings: GradeSettings, root: Path, plots: bool) -> None:
        self.settings = settings
        self.root = root
        self.plots = plots
        self.running: list[_Running] = []
        self.selector = selectors.DefaultSelector()
        self.wall_timeout = settings.timeout * (1 + HELD_SHARE)  # its time, and time held
        self.cap = self.wall_timeout + settings.own_time_cap

    def _job(self, index: int, student: Student) -> StudentJob:
        s = self.settings
        scratch = self.root / "students" / str(index)
        scratch.mkdir(parents=True)
        return StudentJob(
            name=student.name,
            spec=student.spec,
            problem=student.problem,
            cases=s.cases,
            cycles=s.cycles,
            seed=s.seed,
            timeout=s.timeout,
            ik_timeout=s.ik_timeout,
            memory_mb=s.memory_mb,
            min_success=s.min_success,
            scratch=str(scratch),
            plots=str(self.root / "plots" / str(index)) if self.plots else "",
            jail=s.jail,
            root=student.root,
        )

    def start(self, index: int, student: Student) -> None:
        """Start the grading process of ``student`` (number ``index`` of the class).

        Raises:
            OSError: It could not be started (no memory, no file descriptors, ...).
        """
        job = self._job(index, student)
        env = dict(os.environ, MUJOCO_GL="disable", PYTHONDONTWRITEBYTECODE="1")
        env.setdefault("OMP_NUM_THREADS", "1")
        env.setdefault("OPENBLAS_NUM_THREADS", "1")
        key = secrets.token_bytes(32)
        record_r, record_w = os.pipe()
        try:
            proc = subprocess.Popen(
                [*STUDENT_COMMAND, str(record_w), str(os.getpid())],
                stdin=subprocess.PIPE,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.PIPE,
                pass_fds=(record_w,),
                cwd=os.getcwd(),  # relative SPECs name files from where grade was called
                env=env,
                start_new_session=True,
            )
        except BaseException:
            os.close(record_r)
            raise
        finally:
            os.close(record_w)
        assert proc.stdin is not None and proc.stderr is not None
        run = _Running(index, student, proc, key, time.monotonic())
        self.running.append(run)
        for fd, which in ((record_r, "record"), (proc.stderr.fileno(), "stderr")):
            os.set_blocking(fd, False)
            self.selector.register(fd, selectors.EVENT_READ, (run, which))
            run.fds.append(fd)
        with contextlib.suppress(OSError):  # one that died at once: its exit code says so
            proc.stdin.write(json.dumps({"job": job.to_dict(), "key": key.hex()}).encode())
        with contextlib.suppress(OSError):
            proc.stdin.close()

    def _close(self, run: _Running, fd: int | None = None) -> None:
        for f in list(run.fds) if fd is None else [fd]:
            self.selector.unregister(f)
            run.fds.remove(f)
            err = run.proc.stderr
            if err is not None and not err.closed and f == err.fileno():  # (closed: no fileno)
                err.close()
            else:
                os.close(f)

    def _read(self) -> None:
        for key, _ in self.selector.select(POLL):
            run, which = key.data
            if key.fd not in run.fds:  # closed by an earlier event of this batch
                continue
            try:
                chunk = os.read(key.fd, 1 << 16)
            except BlockingIOError:
                continue
            except OSError:
                chunk = b""
            if not chunk:
                self._close(run, key.fd)
            elif which == "stderr":
                run.stderr += chunk
                del run.stderr[:-STDERR_KEPT]
            else:
                run.record += chunk
                if len(run.record) > RECORD_LIMIT:
                    run.too_big = True
                    _kill(run.proc)
                    self._close(run)

    def poll(self) -> list[dict[str, Any]]:
        """Read what came, for up to :data:`POLL` s; the records of the students that ended."""
        if self.running:
            self._read()
        else:
            time.sleep(POLL)
        done = []
        now = time.monotonic()
        for run in list(self.running):
            if run.proc.poll() is not None:
                run.ended = run.ended or now
                if run.fds and now - run.ended < EOF_GRACE:
                    continue  # the last bytes of its pipes
                try:
                    record = self._finish(run)
                except Exception as exc:  # no record stops the report: it is that student's
                    why = f"the grader could not read its record: {type(exc).__name__}: {exc}"
                    record = blank_record(run.student.name, "", "crashed", one_line(why))
            elif now - run.started > self.cap:
                _kill(run.proc)
                record = blank_record(
                    run.student.name,
                    printable(run.student.spec),
                    "timeout",
                    f"still grading after {self.cap:g} s (--timeout {self.settings.timeout:g} s "
                    f"and as much held off the CPU by others, + our own part's cap "
                    f"{self.settings.own_time_cap:g} s); stopped",
                )
            else:
                continue
            self._close(run)
            self.running.remove(run)
            record["wall_time_s"]["total"] = now - run.started
            done.append(record)
        return done

    def _finish(self, run: _Running) -> dict[str, Any]:
        """The record of a student whose grading process ended (see the module doc)."""
        name, spec = run.student.name, printable(run.student.spec)
        code = run.proc.returncode
        record: dict[str, Any] | None = None
        if run.too_big:
            why = f"the grading process sent more than {RECORD_LIMIT >> 20} MB as its record"
        elif code != 0:
            tail = relevant_line(bytes(run.stderr))
            why = f"the grading process {_ended(code)}" + (f": {tail}" if tail else "")
        else:
            record, why = unseal(bytes(run.record), run.key)
            if record is not None and (bad := record_problem(record)):
                record, why = None, f"its record is unusable: {bad}"
            why = f"the grading process exited with code 0, but {why}"
        if record is None:
            return blank_record(name, spec, "crashed", why)
        record = clean(record)
        record["name"], record["spec"] = name, spec or None  # the grader's, not the record's
        return record

    def stop(self) -> None:
        """Kill every grading process still running and close its pipes."""
        for run in self.running:
            _kill(run.proc)
            self._close(run)
        self.running.clear()
        self.selector.close()


def _confinement(settings: GradeSettings) -> dict[str, Any]:
    """What protects the students' code, for the report: the jail's parts (made once here, so
    a machine where none can be made is refused before any student starts), or, with
    ``--no-jail``, what is not protected (also said on stderr).

    Raises:
        JailUnavailable: No jail can be made here.
    """
    if settings.jail:
        return Jail(memory_mb=settings.memory_mb).describe()
    sys.stderr.write(unjailed_warning("the students'"))
    return unjailed()


def grade(
    students: Sequence[Student],
    settings: GradeSettings,
    report_path: Path | None = None,
    html_path: Path | None = None,
    out: TextIO | None = None,
) -> GradeResult:
    """Grade ``students`` (see the module doc); write the report (and the page).

    Args:
        students: What :func:`~kr210_sim.grading.roster.find_students` found.
        settings: How to grade them.
        report_path: JSON report path (None: not written).
        html_path: The self-contained HTML page (None: none).
        out: Where a line per finished student goes (stdout).

    Returns:
        The report, the table, and the interrupt if one stopped the grading early.

    Raises:
        ConfigError: When the report or page cannot be written (checked first).
        JailUnavailable: ``settings.jail`` where no jail can be made (what to install or
            enable, and ``--no-jail``).
    """
    out = out or sys.stdout
    confinement = _confinement(settings)
    for path in (report_path, html_path):
        if path is not None:
            check_writable(path)
    inputs = {f"student {s.name}": spec_file(s.spec) for s in students if s.spec}
    check_distinct({"--report": report_path, "--html": html_path}, inputs)
    wall0 = time.monotonic()
    root = Path(tempfile.mkdtemp(prefix="kr210_grade_"))
    pool = _Pool(settings, root, html_path is not None)
    pending = list(enumerate(students))
    records: list[dict[str, Any]] = []
    interrupted: KeyboardInterrupt | None = None
    width = len(str(len(students)))

    def finished(record: dict[str, Any]) -> None:
        records.append(record)
        out.write(f"[{len(records):>{width}}/{len(students)}] {student_line(record)}\n")
        out.flush()

    try:  # an interrupt before the first student ends: a report of none, marked interrupted
        end_start_up()  # the command's: a signal held since its start-up is raised here
        while pending or pool.running:
            while pending and len(pool.running) < settings.workers:
                index, student = pending.pop(0)
                if student.problem:
                    finished(blank_record(student.name, "", "error", student.problem))
                    continue
                try:
                    pool.start(index, student)
                except OSError as exc:
                    why = f"its grading process could not be started: {exc.strerror or exc}"
                    finished(blank_record(student.name, printable(student.spec), "crashed", why))
            for record in pool.poll():
                finished(record)
    except KeyboardInterrupt as exc:  # Ctrl-C, SIGTERM, SIGHUP (kr210_sim.util.interrupts)
        interrupted = exc
    except BaseException:
        pool.stop()
        shutil.rmtree(root, ignore_errors=True)
        raise
    with winding_up(interrupted):  # whatever signals follow: the students stopped, the report whole
        if interrupted is not None:
            sys.stderr.write(
                f"kr210_sim: interrupted ({signal_name(interrupted)}) after {len(records)} of "
                f"{len(students)} students; writing the report of those\n"
            )
        pool.stop()
        shutil.rmtree(root, ignore_errors=True)
        config = {**settings.config(), "confinement": confinement}
        wall = time.monotonic() - wall0
        report = build_report(records, config, settings.workers, wall, interrupted)
        if report_path is not None:
            write_json_atomic(report_path, report)
        written = None
        if html_path is not None:
            write_html(html_path, report, records)
            written = html_path
    return GradeResult(report, table(report), interrupted, written, records)
