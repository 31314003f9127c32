"""One student's grading: ik-check and a run with the student's IK in its sandbox, one record.

:func:`grade_student` is what ``grade`` does per student. The grader runs it in a process of
its own (``python -m kr210_sim.eval.student JOB OUT``: the job as JSON in, the record as JSON
out), which starts the student's IK in a sandbox (:class:`~kr210_sim.robot.ik_sandbox.IkSandbox`,
``stop=True``): the simulation and every check run here, the student's code only there. The
first fault ends the student: a hang is ``timeout``, a dead process ``crashed``, an import or
syntax error ``error``. Otherwise the verdict is ``pass`` when every ik-check case passes and the
run reaches the pass bar, else ``fail``, with the figures and the mistakes
:mod:`kr210_sim.eval.diagnose` recognises.
"""

from __future__ import annotations

import base64
import io
import json
import math
import shlex
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from kr210_sim.eval.diagnose import diagnose
from kr210_sim.eval.ikcheck import Case, check, fixed_cases, random_cases, summarise
from kr210_sim.robot.description import load_robot
from kr210_sim.robot.ik_sandbox import IkSandbox, Limits, SandboxStop
from kr210_sim.robot.kinematics import Kinematics
from kr210_sim.robot.user_ik import UserIk
from kr210_sim.score.result import CycleResult
from kr210_sim.sim.runner import RunConfig, Runner
from kr210_sim.sim.session import run_session
from kr210_sim.util.outputs import write_json_atomic
from kr210_sim.util.processes import die_with_parent

#: The verdicts, best first (the leaderboard's order).
VERDICTS = ("pass", "fail", "timeout", "crashed", "error")


@dataclass(frozen=True, slots=True)
class StudentJob:
    """What to grade and how.

    Attributes:
        name: The student's name (file or folder name).
        spec: SPEC of the student's ``solve`` ("" when ``problem`` says why there is none).
        problem: Why the submission cannot be graded at all ("" when it can).
        cases: Random ik-check poses on top of the fixed set.
        cycles: Cycles of the run.
        seed: Seed of the random poses and of the run.
        timeout: Time for the whole student [s].
        ik_timeout: Time per IK call [s].
        memory_mb: Memory limit of the student's process (RLIMIT_AS) [MB].
        min_success: The run's pass bar (share of cycles).
        scratch: The student's scratch folder (its working folder).
        plots: Folder for the error plots (embedded in the record as PNG), or "" for none.
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

    def to_dict(self) -> dict[str, Any]:
        """The job as JSON-ready values."""
        return asdict(self)


def replay_command(job: StudentJob, cycle: int) -> str:
    """The command that runs the student's cycles 1..``cycle`` again and films them (the
    cell carries over between cycles, so the failed one is filmed last)."""
    video = f"videos/{job.name}_cycle{cycle}.mp4"
    return (
        f"python -m kr210_sim run --ik {shlex.quote(job.spec)} --ik-timeout {job.ik_timeout:g} "
        f"--cycles {cycle} --seed {job.seed} --video {shlex.quote(video)}"
    )


def _ik_figures(records: list[dict[str, Any]]) -> dict[str, Any]:
    s = summarise(records)
    return {
        "cases": s["cases"],
        "passed": s["passed"],
        "max_position_error_m": s["max_position_error_m"],
        "max_orientation_error_rad": s["max_orientation_error_rad"],
        "outside_limits": s["outside_limits"],
        "raised": s["raised"],
        "returned_none": s["returned_none"],
        "branch_changes": s["branch_changes"],
        "wall_time_per_call_s": s["wall_time_s"]["per_call_mean"],
    }


def _run_figures(job: StudentJob, results: list[CycleResult]) -> dict[str, Any]:
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
        "cycles": len(results),
        "successes": sum(r.success for r in results),
        "failures": failures,
        "failed_cycles": failed,
    }


def _plots(folder: Path, records: list[dict[str, Any]]) -> dict[str, str]:
    from kr210_sim.eval.ikcheck import write_plots

    return {p.name: base64.b64encode(p.read_bytes()).decode() for p in write_plots(folder, records)}


def _verdict(job: StudentJob, ik: dict[str, Any], run: dict[str, Any]) -> tuple[str, str]:
    need = math.ceil(job.min_success * job.cycles - 1e-9)
    ik_ok = ik["passed"] == ik["cases"]
    run_ok = run["successes"] >= need
    text = (
        f"ik-check {ik['passed']}/{ik['cases']} cases, run {run['successes']}/{job.cycles} "
        f"cycles (pass bar {need})"
    )
    return ("pass" if ik_ok and run_ok else "fail"), text


def grade_student(job: StudentJob) -> dict[str, Any]:
    """Grade one student (see the module doc); the record the report keeps.

    Returns:
        ``name``, ``spec``, ``verdict``, ``detail``, ``ik_check`` and ``run`` figures (None when
        that part did not finish), ``diagnosis``, the student's captured ``output`` and
        ``wall_time_s``; with ``job.plots`` also ``plots`` (PNG files as base64, for the page).
    """
    wall0 = time.monotonic()
    record: dict[str, Any] = {
        "name": job.name,
        "spec": job.spec or None,
        "verdict": "error",
        "detail": job.problem,
        "ik_check": None,
        "run": None,
        "diagnosis": [],
        "output": {"bytes": 0, "stdout": "", "stderr": ""},
        "wall_time_s": {"ik_check": None, "run": None, "total": 0.0},
    }
    if job.problem:
        return record
    sandbox = IkSandbox(
        job.spec,
        Limits(call_timeout=job.ik_timeout, memory_mb=job.memory_mb),
        scratch=Path(job.scratch),
        capture=True,
        stop=True,
        deadline=wall0 + job.timeout,
    )
    ik = UserIk(job.spec, sandbox)
    records: list[dict[str, Any]] = []
    cases: list[Case] = []
    runner: Runner | None = None
    stopped: SandboxStop | None = None
    stage = ""  # where a stop happened, for its detail
    try:
        sandbox.start()
        kin = Kinematics(load_robot())
        cases = fixed_cases(kin) + random_cases(kin, job.cases, job.seed)
        t = time.monotonic()
        stage = "ik-check"
        records = check(kin, ik, cases, io.StringIO())
        record["wall_time_s"]["ik_check"] = time.monotonic() - t
        record["ik_check"] = _ik_figures(records)
        runner = Runner(RunConfig(cycles=job.cycles, seed=job.seed), ik=ik)
        stage = "run, cycle 1"

        def next_cycle(done: int) -> None:
            nonlocal stage
            stage = f"run, cycle {done + 1}"

        end = run_session(runner, io.StringIO(), after=next_cycle, stops=(SandboxStop,))
        if isinstance(end.interrupted, SandboxStop):
            raise end.interrupted
        record["wall_time_s"]["run"] = end.wall_time
    except SandboxStop as exc:
        stopped = exc
    finally:
        sandbox.close()
    results = list(runner.results) if runner is not None else []
    run = _run_figures(job, results)
    if runner is not None:
        record["run"] = run
        if runner.planner.user_ik is not None:
            record["run"]["wall_time_per_call_s"] = runner.planner.user_ik.stats.mean
    if stopped is not None:
        where = stage
        if stage == "ik-check" and 0 < sandbox.calls <= len(cases):
            n = sandbox.calls
            where = f"ik-check case {n} of {len(cases)}: {cases[n - 1].name}"
        detail = f"{stopped.detail} ({where})" if where else stopped.detail
        record["verdict"], record["detail"] = stopped.verdict, detail
    else:
        record["verdict"], record["detail"] = _verdict(job, record["ik_check"], run)
    if records and len(records) == len(cases):
        found = diagnose(kin, records, [c.T for c in cases], run["failed_cycles"])
        record["diagnosis"] = [f.to_dict() for f in found]
        if job.plots:
            record["plots"] = _plots(Path(job.plots), records)
    out, err = sandbox.stdout, sandbox.stderr
    record["output"] = {
        "bytes": out.total + err.total,
        "stdout": out.text(),
        "stderr": err.text(),
    }
    record["wall_time_s"]["total"] = time.monotonic() - wall0
    return record


def main(argv: list[str]) -> int:
    """``python -m kr210_sim.eval.student JOB OUT PARENT``: grade the job in the JSON file JOB,
    write the record to OUT atomically; die with process PARENT."""
    die_with_parent(int(argv[2]))
    job = StudentJob(**json.loads(Path(argv[0]).read_text()))
    write_json_atomic(Path(argv[1]), grade_student(job))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
