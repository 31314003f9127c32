"""One student's grading: ik-check and a run with the student's IK in its sandbox, one record.

:func:`grade_student` is what ``grade`` does per student. The grader runs it in a process of
its own, the *grading process* (:data:`STUDENT_COMMAND`, :func:`main`), which starts the
student's IK in a sandbox (:class:`~kr210_sim.sandbox.ik_sandbox.IkSandbox`, ``stop=True``): the
simulation and every check run in the grading process, the student's code only in the sandbox.
The first fault ends the student: a hang is ``timeout``, a dead process ``crashed``, an import or
syntax error ``error``. Otherwise the verdict is ``pass`` when every ik-check case passes and the
run reaches the pass bar, else ``fail``, with the figures and the mistakes
:mod:`kr210_sim.grading.diagnose` recognises.

The student's time limit (``timeout``, ``grade --timeout``) counts the student's own time only
(:class:`~kr210_sim.grading.clock.StudentClock`): importing its module, and each call from the
pose sent to the answer back, less the time other processes held it off the CPU. Our checks,
planning and simulation do not count against it. Within it, a slow student is
graded on what fits (:mod:`kr210_sim.grading.budget`): the ``ik_debug`` and ``cell`` cases first,
then the run cycle by cycle while a cycle fits, then the other cases while they fit; the
record says how many cases and cycles were tried, and the pass bar applies to the cycles run.
An original-form ROS server (:mod:`kr210_sim.exercise`) is asked for many poses at once
(:meth:`StudentClock.batch`), and what Python 2 semantics changed in its code comes back as
notes for the diagnosis.
"""

from __future__ import annotations

import base64
import contextlib
import hashlib
import io
import json
import math
import os
import re
import shlex
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from kr210_sim.errors import IkSpecError
from kr210_sim.grading.budget import Budget, chunks, need_text, split
from kr210_sim.grading.clock import StudentClock
from kr210_sim.grading.diagnose import diagnose
from kr210_sim.grading.finding import exact_singular, grader_code, one_branch
from kr210_sim.grading.ikcheck import Case, check, fixed_cases, random_cases, summarise
from kr210_sim.grading.record import VERDICTS, blank_record, seal
from kr210_sim.robot.description import load_robot
from kr210_sim.robot.kinematics import Kinematics
from kr210_sim.sandbox.bwrap import JailUnavailable
from kr210_sim.sandbox.confine import Unconfined
from kr210_sim.sandbox.held import HELD_SHARE
from kr210_sim.sandbox.ik_sandbox import IkSandbox, Limits, SandboxStop
from kr210_sim.sandbox.jail import Jail
from kr210_sim.sandbox.user_ik import UserIk
from kr210_sim.score.result import CycleResult
from kr210_sim.sim.runner import RunConfig, Runner
from kr210_sim.sim.session import run_session
from kr210_sim.util.processes import die_with_parent

__all__ = [
    "STUDENT_COMMAND",
    "VERDICTS",
    "StudentClock",
    "StudentJob",
    "grade_student",
    "main",
    "replay_command",
    "student_sandbox",
]

FloatArray = npt.NDArray[np.float64]

#: The grading process: :func:`main` with ``RECORD_FD PARENT_PID`` (the job on its stdin).
#: ``-c``, not ``-m``: running this module as ``__main__`` after the package imported it gave
#: every grading process a runpy RuntimeWarning. ``-P``: its working folder (often the class
#: folder) is not on ``sys.path``, so no student's ``ruckig/`` or ``numpy.py`` is imported here,
#: outside the jail; a module SPEC there is still found (located, not run) by
#: :func:`~kr210_sim.sandbox.user_ik.find_module`.
STUDENT_COMMAND = (
    sys.executable,
    "-P",
    "-c",
    "import sys; from kr210_sim.grading.student import main; sys.exit(main(sys.argv[1:]))",
)
#: Longest student name a film-it command's video file is named by [characters].
VIDEO_NAME = 64
PR_SET_DUMPABLE = 4


@dataclass(frozen=True, slots=True)
class StudentJob:
    """What to grade and how.

    Attributes:
        name: The student's name (file or folder name, as shown).
        spec: SPEC of the student's ``solve`` ("" when ``problem`` says why there is none).
        problem: Why the submission cannot be graded at all ("" when it can).
        cases: Random ik-check poses on top of the fixed set.
        cycles: Cycles of the run.
        seed: Seed of the random poses and of the run.
        timeout: The student's own time, in all (:class:`StudentClock`) [s].
        ik_timeout: Time per IK call [s].
        memory_mb: Memory limit of the student's process (RLIMIT_AS) [MB].
        min_success: The run's pass bar (share of cycles).
        scratch: The student's scratch folder (its working folder).
        plots: Folder for the error plots (embedded in the record as PNG), or "" for none.
        jail: Run the student's IK in a bubblewrap jail (:class:`~kr210_sim.sandbox.jail.Jail`).
        root: The student's own files, all of its that the jail shows it ("": the SPEC's).
    """

    name: str
    spec: str
    problem: str
    cases: int
    cycles: int
    seed: int
    timeout: float
    ik_timeout: float
    memory_mb: int
    min_success: float
    scratch: str
    plots: str = ""
    jail: bool = True
    root: str = ""

    def to_dict(self) -> dict[str, Any]:
        """The job as JSON-ready values."""
        return asdict(self)


def shell_word(text: str) -> str:
    """``text`` as one word of a POSIX shell command line; a file name's undecodable bytes
    (surrogate escapes) as ``$'\\xNN'`` (bash, zsh, ksh), so the command names the same file."""
    raw = os.fsencode(text)
    try:
        decoded = raw.decode("utf-8")
    except UnicodeDecodeError:
        decoded = ""
    if decoded == text and text.isprintable():
        return shlex.quote(text)
    escaped = "".join(
        chr(b) if 0x20 <= b < 0x7F and b not in b"'\\" else f"\\x{b:02x}" for b in raw
    )
    return f"$'{escaped}'"


def video_name(name: str) -> str:
    """A file name for a student's video: letters, digits, ``.``, ``_``, ``-`` of its name
    (others as ``_``), at most :data:`VIDEO_NAME` characters (a longer one cut, with a hash)."""
    safe = re.sub(r"[^A-Za-z0-9._-]", "_", name)
    if len(safe) <= VIDEO_NAME:
        return safe
    digest = hashlib.sha1(os.fsencode(name)).hexdigest()[:8]
    return f"{safe[: VIDEO_NAME - 9]}_{digest}"


def replay_command(job: StudentJob, cycle: int) -> str:
    """The command that runs the student's cycles 1..``cycle`` again and films them (the
    cell carries over between cycles, so the failed one is filmed last), as a shell line
    run from where ``grade`` was called. A folder student's jail shows its folder, as
    ``grade``'s did (``--ik-root``)."""
    spec = f"./{job.spec}" if job.spec.startswith("-") else job.spec  # not read as an option
    video = f"videos/{video_name(job.name)}_cycle{cycle}.mp4"
    root = ""
    if job.root and Path(job.root).is_dir():
        folder = f"./{job.root}" if job.root.startswith("-") else job.root
        root = f"--ik-root {shell_word(folder)} "
    return (
        f"python -m kr210_sim run --ik {shell_word(spec)} --ik-timeout {job.ik_timeout:g} "
        f"{root}--cycles {cycle} --seed {job.seed} --video {shlex.quote(video)}"
    )


def _ik_figures(records: list[dict[str, Any]], total: int) -> dict[str, Any]:
    """The ik-check's figures: ``cases`` are those tried, ``cases_total`` those there were,
    ``one_branch`` and ``exact_singular`` the failed cases
    :func:`~kr210_sim.grading.finding.one_branch` and
    :func:`~kr210_sim.grading.finding.exact_singular` name (a ROS-form server is not failed for
    them)."""
    s = summarise(records)
    return {
        "cases": s["cases"],
        "cases_total": total,
        "passed": s["passed"],
        "one_branch": sum(one_branch(r) for r in records),
        "exact_singular": sum(exact_singular(r) and not one_branch(r) for r in records),
        "max_position_error_m": s["max_position_error_m"],
        "max_orientation_error_rad": s["max_orientation_error_rad"],
        "outside_limits": s["outside_limits"],
        "raised": s["raised"],
        "returned_none": s["returned_none"],
        "branch_changes": s["branch_changes"],
        "wall_time_per_call_s": s["wall_time_s"]["per_call_mean"],
    }


def _run_figures(job: StudentJob, results: list[CycleResult]) -> dict[str, Any]:
    """The run's figures: ``cycles`` is the cycles asked for, ``cycles_run`` those that ran
    (fewer when the student was stopped)."""
    failures: dict[str, int] = {}
    failed = []
    for r in results:
        if r.success:
            continue
        reason = str(r.reason)
        failures[reason] = failures.get(reason, 0) + 1
        failed.append(
            {
                "cycle": r.index,
                "slot": r.slot,
                "reason": reason,
                "detail": r.detail,
                "replay": replay_command(job, r.index),
            }
        )
    return {
        "cycles": job.cycles,
        "cycles_run": len(results),
        "successes": sum(r.success for r in results),
        "failures": failures,
        "failed_cycles": failed,
    }


def _plots(folder: Path, records: list[dict[str, Any]]) -> dict[str, str]:
    from kr210_sim.grading.ikcheck import write_plots

    return {p.name: base64.b64encode(p.read_bytes()).decode() for p in write_plots(folder, records)}


def _verdict(
    job: StudentJob,
    ik: dict[str, Any],
    run: dict[str, Any],
    budget: Budget | None = None,
    ros: bool = False,
) -> tuple[str, str]:
    """``pass`` when every case tried passed and the run reached its pass bar (over the cycles
    run, when the time budget cut the run), else ``fail``; and the one line that says so.

    A ROS-form server (``ros``) is graded on what the exercise asked of it: its one branch
    inside the limits for the exercise's own cases (:data:`~kr210_sim.grading.budget.FIRST`), and
    poses reached elsewhere; a case that only another branch reaches inside the limits
    (``ik["one_branch"]``), and a case at the exact singular wrist (``ik["exact_singular"]``,
    q5 = 0, a pose the exercise never asked for), are counted and said, not failed. A function
    of our form is asked for the nearest of all branches and given ``q_ref``, which answers the
    singular wrist too, so every case counts."""
    cut = budget is not None and budget.cut_run
    cycles = run["cycles_run"] if cut else job.cycles
    need = math.ceil(job.min_success * cycles - 1e-9)
    branch = ik.get("one_branch", 0) if ros else 0
    straight = ik.get("exact_singular", 0) if ros else 0
    ik_ok = ik["passed"] + branch + straight == ik["cases"]
    run_ok = run["successes"] >= need
    cases = f"ik-check {ik['passed']}/{ik['cases']} cases"
    if branch:
        cases += (
            f" ({branch} more answers reach their pose outside the joint limits, where only "
            "another branch reaches it inside them: one branch, as the exercise's IK, not failed)"
        )
    if straight:
        cases += (
            f" ({straight} more at the exact singular wrist, q5 = 0, where only theta4 + theta6 "
            "is defined and a server is sent no joint state to split them by: a pose the "
            "exercise never asked for, not failed)"
        )
    if ik["cases"] < ik.get("cases_total", ik["cases"]):
        cases += f" (tried {ik['cases']} of {ik['cases_total']} in --timeout {job.timeout:g} s)"
    if not cut:
        ran = f"run {run['successes']}/{job.cycles} cycles (pass bar {need})"
    elif cycles:
        ran = (
            f"run {run['successes']}/{cycles} cycles (pass bar {need}; {cycles} of "
            f"{job.cycles} fitted in --timeout {job.timeout:g} s)"
        )
    else:
        ran = f"run not tried ({run.get('not_tried', 'no cycle fitted in --timeout')})"
    return ("pass" if ik_ok and run_ok else "fail"), f"{cases}, {ran}"


class _BudgetCut(Exception):
    """The next cycle does not fit in the student's time left (ends the run, not the student)."""


def student_sandbox(job: StudentJob) -> IkSandbox:
    """The sandbox the student's IK runs in (not started): with ``job.jail`` in a jail that
    shows it only its own files (``job.root``); ``job``'s memory limit and time per call, CPU
    time up to the most wall time its whole time may take (``job.timeout`` and as much held off
    the CPU: :data:`~kr210_sim.sandbox.held.HELD_SHARE`; a student charged its CPU time would
    otherwise meet ``RLIMIT_CPU`` as its budget ran out, ``crashed``), its scratch folder, its
    output captured, the first fault a stop;
    the import may take the student's whole time (``job.timeout``), which
    :class:`StudentClock` then bounds.

    Raises:
        JailUnavailable: ``job.jail`` on a machine where no jail can be made.
    """
    confinement = Jail(memory_mb=job.memory_mb) if job.jail else Unconfined()
    limits = Limits(
        call_timeout=job.ik_timeout,
        memory_mb=job.memory_mb,
        load_timeout=job.timeout,
        cpu_s=job.timeout * (1 + HELD_SHARE),
    )
    return IkSandbox(
        job.spec,
        limits,
        scratch=Path(job.scratch),
        capture=True,
        stop=True,
        confinement=confinement,
        root=Path(job.root) if job.root else None,
    )


def grade_student(job: StudentJob) -> dict[str, Any]:
    """Grade one student (see the module doc); the record the report keeps.

    Returns:
        ``name``, ``spec``, ``verdict``, ``detail``, ``ik_check`` and ``run`` figures (None when
        that part did not start), ``diagnosis``, the student's captured ``output`` and
        ``wall_time_s`` (``student``: its own time, :class:`StudentClock`); with ``job.plots``
        also ``plots`` (PNG files as base64, for the page).
    """
    wall0 = time.monotonic()
    record = blank_record(job.name, job.spec, "error", job.problem)
    if job.problem:
        return record
    try:
        sandbox = student_sandbox(job)
    except (JailUnavailable, IkSpecError) as exc:  # IkSpecError: a file of its not read
        record["detail"] = str(exc)
        return record
    clock = StudentClock(sandbox, job.timeout)
    ik = UserIk(job.spec, clock, batch=clock.batch if sandbox.ros else None)
    budget = Budget(clock, sandbox)
    records: list[dict[str, Any]] = []
    cases: list[Case] = []
    runner: Runner | None = None
    stopped: SandboxStop | None = None
    stage = ""  # where a stop happened, for its detail
    at = (0, 0)  # the chunk being checked: its first case's index, the poses asked before it
    checking = 0.0  # wall time of the ik-check [s]
    not_tried = ""  # why the run was not begun

    def tried(todo: list[Case], start: int, fits: bool) -> None:
        """Check ``todo`` (cases ``start``... of ``cases``) chunk by chunk; with ``fits``
        only while they fit in the budget (:meth:`Budget.rest_fits`)."""
        nonlocal stage, at, checking
        done = start
        for chunk in chunks(todo):
            n = budget.rest_fits(len(chunk)) if fits else len(chunk)
            if n == 0:
                return
            stage, at = "ik-check", (done, sandbox.poses)
            t = time.monotonic()
            records.extend(check(kin, ik, chunk[:n], io.StringIO()))
            checking += time.monotonic() - t
            done += n

    try:
        clock.start()
        kin = Kinematics(load_robot())
        cases = fixed_cases(kin) + random_cases(kin, job.cases, job.seed)
        first, rest = split(cases)
        tried(first, 0, fits=False)
        record["ik_check"] = _ik_figures(records, len(cases))
        runner = Runner(RunConfig(cycles=job.cycles, seed=job.seed), ik=ik)
        started = clock.used

        def next_cycle(done: int) -> None:
            nonlocal stage, started
            took, started = clock.used - started, clock.used
            if done < job.cycles and not budget.cycle_fits(took):
                raise _BudgetCut
            stage = f"run, cycle {done + 1}"

        if budget.cycle_fits(None):
            stage = "run, cycle 1"
            end = run_session(
                runner, io.StringIO(), after=next_cycle, stops=(SandboxStop, _BudgetCut)
            )
            if isinstance(end.interrupted, SandboxStop):
                if not clock.spent:
                    raise end.interrupted
                budget.cut_run = True  # the budget ran out in a cycle: the cycles before count
            record["wall_time_s"]["run"] = end.wall_time
        else:
            not_tried = need_text(budget)
        if not clock.spent:
            tried(rest, len(first), fits=True)
        record["wall_time_s"]["ik_check"] = checking
    except SandboxStop as exc:
        if exc.verdict == "timeout" and clock.spent and runner is not None:
            budget.cut_cases = True  # the cases after the run ran out of time: those tried count
            record["wall_time_s"]["ik_check"] = checking
        else:
            stopped = exc
    finally:
        sandbox.close()
    results = list(runner.results) if runner is not None else []
    run = _run_figures(job, results)
    if records:
        record["ik_check"] = _ik_figures(records, len(cases))
    if runner is not None:
        record["run"] = run
        if runner.planner.user_ik is not None:
            record["run"]["wall_time_per_call_s"] = runner.planner.user_ik.stats.mean
        if not_tried:
            record["run"]["not_tried"] = not_tried
    if stopped is not None:
        where = stage
        if stage == "ik-check":
            n = at[0] + sandbox.poses - at[1]  # the case in flight (the last of a batch)
            if ik.batch is not None:
                where = f"ik-check cases {at[0] + 1}-{n} of {len(cases)}"
            elif 0 < n <= len(cases):
                where = f"ik-check case {n} of {len(cases)}: {cases[n - 1].name}"
        what = stopped.detail
        if stopped.verdict == "timeout" and clock.spent:
            what = clock.spent_detail()
        record["verdict"] = stopped.verdict
        record["detail"] = f"{what} ({where})" if where else what
    else:
        record["verdict"], record["detail"] = _verdict(
            job, record["ik_check"], run, budget, ros=sandbox.ros
        )
    if records:
        poses = [c.T for c in cases[: len(records)]]
        found = diagnose(
            kin, records, poses, run["failed_cycles"], sandbox.notes, no_q_ref=ik.batch is not None
        )
        record["diagnosis"] = [f.to_dict() for f in found]
        if job.plots:
            record["plots"] = _plots(Path(job.plots), records)
    if (taken := grader_code(sandbox.blocked)) is not None:  # named in the verdict
        record["diagnosis"] = [taken.to_dict(), *record.get("diagnosis", [])]
        record["detail"] += f"; {taken.text}"
    out, err = sandbox.stdout, sandbox.stderr
    record["output"] = {
        "bytes": out.total + err.total,
        "stdout": out.text(),
        "stderr": err.text(),
    }
    stopped_by_jail = sandbox.confinement.findings()
    record["jail"] = {**sandbox.confinement.describe(), "stopped": stopped_by_jail}
    if isinstance(sandbox.confinement, Jail):
        record["jail"]["cpu_s"] = round(sandbox.confinement.cpu_s, 3)
        if (peak := sandbox.confinement.memory_peak) is not None:
            record["jail"]["memory_peak_mb"] = round(peak / (1 << 20), 1)
    if stopped_by_jail:
        record["detail"] += f"; the jail stopped: {'; '.join(stopped_by_jail)}"
    record["wall_time_s"]["student"] = clock.used
    record["wall_time_s"]["held_off_cpu"] = round(clock.held, 3)
    record["wall_time_s"]["total"] = time.monotonic() - wall0
    return record


def _not_dumpable() -> None:
    """Make this process non-dumpable (``PR_SET_DUMPABLE`` = 0): a process of the same user
    that is not root (the student's) can then neither open this process's ``/proc`` files
    (its pipes) nor trace it. Linux only; elsewhere nothing is set."""
    import ctypes

    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_DUMPABLE, 0, 0, 0, 0)


def main(argv: list[str]) -> int:
    """The grading process: ``RECORD_FD PARENT_PID``, the job on standard input as JSON
    (``{"job": StudentJob fields, "key": hex}``). Grades the job and writes its record to the
    pipe RECORD_FD as one sealed frame (:func:`~kr210_sim.grading.record.seal`); dies with
    process PARENT_PID."""
    fd, parent = int(argv[0]), int(argv[1])
    die_with_parent(parent)
    _not_dumpable()
    os.set_inheritable(fd, False)  # no process started from here holds the record pipe
    given = json.loads(sys.stdin.buffer.read())
    key = bytes.fromhex(given["key"])
    record = grade_student(StudentJob(**given["job"]))
    with os.fdopen(fd, "wb") as pipe:
        pipe.write(seal(record, key))
    return 0
