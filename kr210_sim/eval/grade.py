"""``grade``: many students' IK solutions, each in its own sandbox, one leaderboard.

A SUBMISSION is a SPEC (``path/file.py:function``), a ``.py`` file (its ``solve``), or a folder:
each ``.py`` file in it is one student, named by the file, and each subfolder is one student,
named by the folder, whose ``solve`` is in :data:`STUDENT_MODULE` (or in the folder's only
``.py`` file). Files and folders whose names start with ``.`` or ``_`` are skipped.

Each student is graded in a process of its own (:mod:`kr210_sim.eval.student`), at most
``workers`` at a time; that process runs the student's IK in a sandbox
(:mod:`kr210_sim.robot.ik_sandbox`). Every process is started in a session of its own and dies
with its parent (``PR_SET_PDEATHSIG``); on Ctrl-C or SIGTERM the running students are killed, the
report of the students finished so far is written, and the exit code says which signal it was.
The scratch folders (one per student, the student's working folder) live in one temporary folder
that is removed at the end.
"""

from __future__ import annotations

import contextlib
import json
import os
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
from kr210_sim.eval.leaderboard import build_report, student_line, table, write_html
from kr210_sim.eval.student import StudentJob
from kr210_sim.robot.ik_sandbox import DEFAULT_MEMORY_MB, MIN_MEMORY_MB
from kr210_sim.robot.user_ik import split_spec
from kr210_sim.util.interrupts import signal_name

#: The module a student's folder keeps its ``solve`` in.
STUDENT_MODULE = "ik.py"
#: The function a ``.py`` file or a folder is graded by.
STUDENT_FUNCTION = "solve"
#: Time our own part of a student (start-up, simulation) may add to ``timeout`` before the
#: grader kills the student's process itself [s].
GRACE = 60.0
#: The process that grades one student (:func:`kr210_sim.eval.student.main`).
STUDENT_COMMAND = (sys.executable, "-m", "kr210_sim.eval.student")
#: How often the grader looks at its running students [s].
POLL = 0.05


@dataclass(frozen=True, slots=True)
class Student:
    """One submission to grade.

    Attributes:
        name: File or folder name (a SPEC's file name without ``.py``).
        spec: SPEC of its ``solve`` ("" when ``problem`` is set).
        problem: Why it cannot be graded (a folder without :data:`STUDENT_MODULE`), or "".
    """

    name: str
    spec: str
    problem: str = ""


@dataclass(frozen=True, slots=True)
class GradeSettings:
    """How every student is graded.

    Attributes:
        cases: Random ik-check poses on top of the fixed set.
        cycles: Cycles of the run.
        seed: Seed of the random poses and of the run.
        timeout: Time per student [s].
        ik_timeout: Time per IK call [s].
        memory_mb: Memory limit of each student's process [MB].
        workers: Students graded at once.
        min_success: The run's pass bar (share of ``cycles``).
    """

    cases: int = 1000
    cycles: int = 10
    seed: int = 0
    timeout: float = 120.0
    ik_timeout: float = 2.0
    memory_mb: int = DEFAULT_MEMORY_MB
    workers: int = 1
    min_success: float = 0.8

    def __post_init__(self) -> None:
        if self.memory_mb < MIN_MEMORY_MB:
            raise ConfigError(f"--memory must be at least {MIN_MEMORY_MB} MB, got {self.memory_mb}")
        if not (self.timeout > 0 and self.ik_timeout > 0):
            raise ConfigError("--timeout and --ik-timeout must be > 0 s")
        if self.workers < 1:
            raise ConfigError(f"--workers must be at least 1, got {self.workers}")

    def config(self) -> dict[str, Any]:
        """The report's ``config``: what every student is graded with."""
        return {
            "cases": self.cases,
            "cycles": self.cycles,
            "seed": self.seed,
            "timeout_s": self.timeout,
            "ik_timeout_s": self.ik_timeout,
            "memory_mb": self.memory_mb,
            "min_success": self.min_success,
        }


def _folder_student(folder: Path) -> Student:
    module = folder / STUDENT_MODULE
    if module.is_file():
        return Student(folder.name, f"{module}:{STUDENT_FUNCTION}")
    files = [p for p in sorted(folder.glob("*.py")) if not p.name.startswith((".", "_"))]
    if len(files) == 1:
        return Student(folder.name, f"{files[0]}:{STUDENT_FUNCTION}")
    found = f"{len(files)} .py files" if files else "no .py file"
    return Student(folder.name, "", f"no {STUDENT_MODULE} in {folder} ({found})")


def find_students(submissions: Sequence[str]) -> list[Student]:
    """The students the SUBMISSION arguments name, in the order given (folders sorted by name).

    Raises:
        ConfigError: A SUBMISSION that does not exist, is not a ``.py`` file, a folder or a
            SPEC, a folder with no student in it, or two students with one name.
    """
    students: list[Student] = []
    for text in submissions:
        path = Path(text)
        if path.is_dir():
            found = []
            for p in sorted(path.iterdir()):
                if p.name.startswith((".", "_")):
                    continue
                if p.is_dir():
                    found.append(_folder_student(p))
                elif p.suffix == ".py" and p.is_file():
                    found.append(Student(p.stem, f"{p}:{STUDENT_FUNCTION}"))
            if not found:
                raise ConfigError(f"{text}: no student in this folder (no .py file, no subfolder)")
            students.extend(found)
        elif path.suffix == ".py":
            if not path.is_file():
                raise ConfigError(f"{text}: no such file")
            students.append(Student(path.stem, f"{path}:{STUDENT_FUNCTION}"))
        elif ":" in text:
            where, _ = split_spec(text)
            if where.endswith(".py") and not Path(where).is_file():
                raise ConfigError(f"{text}: no such file {where}")
            students.append(Student(Path(where).stem if where.endswith(".py") else where, text))
        else:
            raise ConfigError(f"{text}: not a folder, a .py file or a SPEC (path/file.py:function)")
    seen: dict[str, int] = {}
    for s in students:
        seen[s.name] = seen.get(s.name, 0) + 1
    twice = sorted(n for n, k in seen.items() if k > 1)
    if twice:
        raise ConfigError(f"two students named {twice[0]!r}: grade them in separate calls")
    return students


@dataclass
class _Running:
    student: Student
    proc: subprocess.Popen[bytes]
    started: float
    out: Path


@dataclass
class GradeResult:
    """What ``grade`` produced.

    Attributes:
        report: The JSON-ready report (students sorted as the leaderboard).
        text: The leaderboard table.
        interrupted: The interrupt that stopped the grading, or None.
        html_path: The page written (None without ``--html``).
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


def _lost(student: Student, why: str, seconds: float) -> dict[str, Any]:
    """The record of a student whose grading process gave no record."""
    return {
        "name": student.name,
        "spec": student.spec or None,
        "verdict": "crashed",
        "detail": why,
        "ik_check": None,
        "run": None,
        "diagnosis": [],
        "output": {"bytes": 0, "stdout": "", "stderr": ""},
        "wall_time_s": {"ik_check": None, "run": None, "total": seconds},
    }


def _kill(proc: subprocess.Popen[bytes]) -> None:
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(proc.pid, signal.SIGKILL)
    with contextlib.suppress(subprocess.TimeoutExpired):
        proc.wait(timeout=10.0)


def _finish(run: _Running) -> dict[str, Any]:
    """The record of a student whose process ended."""
    seconds = time.monotonic() - run.started
    try:
        record: dict[str, Any] = json.loads(run.out.read_text())
    except (OSError, ValueError):
        err = run.out.with_suffix(".err")
        tail = ""
        with contextlib.suppress(OSError):
            lines = err.read_text(errors="replace").strip().splitlines()
            tail = f": {lines[-1]}" if lines else ""
        code = run.proc.returncode
        how = f"signal {-code}" if code is not None and code < 0 else f"exit code {code}"
        return _lost(run.student, f"the grading process ended with {how}{tail}", seconds)
    return record


def _start(student: Student, settings: GradeSettings, root: Path, plots: bool) -> _Running:
    scratch = root / "students" / student.name
    scratch.mkdir(parents=True)
    work = root / "grader"
    work.mkdir(exist_ok=True)
    job = StudentJob(
        name=student.name,
        spec=student.spec,
        problem=student.problem,
        cases=settings.cases,
        cycles=settings.cycles,
        seed=settings.seed,
        timeout=settings.timeout,
        ik_timeout=settings.ik_timeout,
        memory_mb=settings.memory_mb,
        min_success=settings.min_success,
        scratch=str(scratch),
        plots=str(work / f"{student.name}.plots") if plots else "",
    )
    job_path = work / f"{student.name}.job.json"
    job_path.write_text(json.dumps(job.to_dict()))
    out = work / f"{student.name}.json"
    env = dict(os.environ, MUJOCO_GL="disable", PYTHONDONTWRITEBYTECODE="1")
    env.setdefault("OMP_NUM_THREADS", "1")
    env.setdefault("OPENBLAS_NUM_THREADS", "1")
    with open(out.with_suffix(".err"), "wb") as err:
        proc = subprocess.Popen(
            [*STUDENT_COMMAND, str(job_path), str(out), str(os.getpid())],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=err,
            cwd=os.getcwd(),  # relative SPECs name files from where grade was called
            env=env,
            start_new_session=True,
        )
    return _Running(student, proc, time.monotonic(), out)


def grade(
    students: Sequence[Student],
    settings: GradeSettings,
    report_path: Path | None = None,
    html_path: Path | None = None,
    out: TextIO | None = None,
) -> GradeResult:
    """Grade ``students`` (see the module doc); write the report (and the page).

    Args:
        students: What :func:`find_students` found.
        settings: How to grade them.
        report_path: JSON report path (None: not written).
        html_path: The self-contained HTML page (None: none).
        out: Where a line per finished student goes (stdout).

    Returns:
        The report, the table, and the interrupt if one stopped the grading early.

    Raises:
        ConfigError: When the report or page cannot be written (checked first).
    """
    from kr210_sim.util.outputs import check_distinct, check_writable

    out = out or sys.stdout
    for path in (report_path, html_path):
        if path is not None:
            check_writable(path)
    inputs: dict[str, Path | None] = {
        f"student {s.name}": Path(split_spec(s.spec)[0]) for s in students if s.spec
    }
    check_distinct({"--report": report_path, "--html": html_path}, inputs)
    wall0 = time.monotonic()
    root = Path(tempfile.mkdtemp(prefix="kr210_grade_"))
    pending = list(students)
    running: list[_Running] = []
    records: list[dict[str, Any]] = []
    interrupted: KeyboardInterrupt | None = None
    width = len(str(len(students)))
    try:
        while pending or running:
            while pending and len(running) < settings.workers:
                running.append(_start(pending.pop(0), settings, root, html_path is not None))
            time.sleep(POLL)
            for run in list(running):
                late = time.monotonic() - run.started > settings.timeout + GRACE
                if run.proc.poll() is None and not late:
                    continue
                running.remove(run)
                if late and run.proc.poll() is None:
                    _kill(run.proc)
                    record = _lost(
                        run.student,
                        f"still grading after {settings.timeout + GRACE:g} s (--timeout + "
                        f"{GRACE:g} s); stopped",
                        time.monotonic() - run.started,
                    )
                    record["verdict"] = "timeout"
                else:
                    record = _finish(run)
                records.append(record)
                out.write(f"[{len(records):>{width}}/{len(students)}] {student_line(record)}\n")
                out.flush()
    except KeyboardInterrupt as exc:  # Ctrl-C, SIGTERM, SIGHUP (kr210_sim.util.interrupts)
        interrupted = exc
        for run in running:
            _kill(run.proc)
        sys.stderr.write(
            f"kr210_sim: interrupted ({signal_name(exc)}) after {len(records)} of "
            f"{len(students)} students; writing the report of those\n"
        )
    finally:
        for run in running:
            _kill(run.proc)
        shutil.rmtree(root, ignore_errors=True)
    report = build_report(
        records, settings.config(), settings.workers, time.monotonic() - wall0, interrupted
    )
    if report_path is not None:
        from kr210_sim.util.outputs import write_json_atomic

        write_json_atomic(report_path, report)
    written = None
    if html_path is not None:
        write_html(html_path, report, records)
        written = html_path
    return GradeResult(report, table(report), interrupted, written, records)
