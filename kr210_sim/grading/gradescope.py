"""One student's verdict as Gradescope's autograder ``results.json`` (``grade --gradescope``).

Gradescope runs an autograder once per submission, in a container of its own, and reads what
it made from ``/autograder/results/results.json`` (its *Autograder Specifications*: a top-level
``score``, ``execution_time`` [s], ``output``, ``visibility`` and ``stdout_visibility``; a list
of ``tests``, each with a ``name``, ``score`` and ``max_score``, a ``status`` of ``passed`` or
``failed``, an ``output`` and its ``visibility``; and a ``leaderboard`` of named values, each
sorted ``asc`` or ``desc``). :func:`results` builds that object from a student's record:

* the score (:func:`~kr210_sim.grading.gradebook.score`, out of 100) and the verdict with its
  detail as the submission's ``output``;
* a test per part: the ik-check (:data:`~kr210_sim.grading.gradebook.IK_POINTS`) and the run
  (:data:`~kr210_sim.grading.gradebook.RUN_POINTS`), each with its figures and its failed cycles
  as ``output``; the diagnosis, every finding, as a test of no points; the student's own output
  (an excerpt) as another;
* the leaderboard: ik-check cases passed, cycles that succeeded, the worst position error [mm]
  and the time per IK call [ms] (the last two when measured).

Every test is ``visible`` (the student sees its figures and diagnosis at once), the grader's
own console (``stdout``) is ``hidden``. Every output is plain ``text``: the texts are the
record's, already escaped (:func:`~kr210_sim.grading.record.clean`), and Gradescope shows them
as text, never as HTML or ANSI.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from kr210_sim.grading.gradebook import IK_POINTS, RUN_POINTS, pass_bar, score
from kr210_sim.util.console import escape

#: Visibility of every test and of the submission's result (Gradescope's ``visible``,
#: ``hidden``, ``after_due_date`` or ``after_published``).
VISIBILITY = "visible"
#: Visibility of the grader's own console (``/autograder/results/stdout``).
STDOUT_VISIBILITY = "hidden"
#: Characters of the student's own output quoted in its test.
OUTPUT_EXCERPT = 4000


def _mm(x: float | None) -> str:
    return "-" if x is None else f"{1000 * x:.3g}"


def _test(name: str, number: str, points: float, of: float, ok: bool, output: str) -> dict:
    return {
        "name": name,
        "number": number,
        "score": points,
        "max_score": of,
        "status": "passed" if ok else "failed",
        "output": output,
        "output_format": "text",
        "visibility": VISIBILITY,
    }


def _ik_output(record: Mapping[str, Any]) -> str:
    ik = record.get("ik_check")
    if not ik:
        return f"not checked: {record['detail']}"
    return (
        f"{ik['passed']} of {ik['cases']} cases passed; worst position error "
        f"{_mm(ik['max_position_error_m'])} mm, worst orientation error "
        f"{_mm(ik['max_orientation_error_rad'])} mrad; {ik['outside_limits']} outside the joint "
        f"limits, {ik['raised']} raised, {ik['returned_none']} returned None"
    )


def _run_output(record: Mapping[str, Any], min_success: float) -> str:
    run = record.get("run")
    if not run:
        return f"not run: {record['detail']}"
    ran = run.get("cycles_run", run["cycles"])
    lines = [
        f"{run['successes']} of {run['cycles']} cycles succeeded (pass bar "
        f"{pass_bar(run, min_success)})"
        + (f"; stopped after {ran}" if ran != run["cycles"] else "")
    ]
    for c in run["failed_cycles"]:
        detail = f": {c['detail']}" if c.get("detail") else ""
        lines.append(f"cycle {c['cycle']} (slot {c['slot']}): {c['reason']}{detail}")
    return "\n".join(lines)


def _leaderboard(record: Mapping[str, Any]) -> list[dict[str, Any]]:
    ik, run = record.get("ik_check") or {}, record.get("run") or {}
    board: list[dict[str, Any]] = [
        {"name": "ik-check cases passed", "value": ik.get("passed", 0), "order": "desc"},
        {"name": "cycles succeeded", "value": run.get("successes", 0), "order": "desc"},
    ]
    if ik.get("max_position_error_m") is not None:
        worst = round(1000 * ik["max_position_error_m"], 6)
        board.append({"name": "worst position error [mm]", "value": worst, "order": "asc"})
    if ik.get("wall_time_per_call_s"):
        per_call = round(1000 * ik["wall_time_per_call_s"], 4)
        board.append({"name": "time per IK call [ms]", "value": per_call, "order": "asc"})
    return board


def results(record: Mapping[str, Any], config: Mapping[str, Any]) -> dict[str, Any]:
    """Gradescope's ``results.json`` object for one student's ``record`` (see the module doc).

    Args:
        record: A checked record, as the grade's report holds it.
        config: The grade's ``config`` (its ``min_success``, ``cases``, ``cycles``).
    """
    min_success = config["min_success"]
    points = score(record, min_success)
    tests = [
        _test(
            f"ik-check: the exercise's poses and {config['cases']} random ones",
            "1",
            points.ik_check,
            IK_POINTS,
            points.ik_check == IK_POINTS,
            _ik_output(record),
        ),
        _test(
            f"run: {config['cycles']} pick-and-place cycles with your IK",
            "2",
            points.run,
            RUN_POINTS,
            points.run == RUN_POINTS,
            _run_output(record, min_success),
        ),
    ]
    found = [f["text"] for f in record.get("diagnosis") or []]
    if found:
        listed = "\n".join(f"- {t}" for t in found)
        ok = record["verdict"] == "pass"  # a pass's findings are notes
        tests.append(_test("diagnosis: what the figures show", "3", 0.0, 0.0, ok, listed))
    out = record.get("output") or {}
    if out.get("bytes"):
        text = (out.get("stdout", "") + out.get("stderr", ""))[:OUTPUT_EXCERPT]
        tests.append(
            _test(
                f"your program's output ({out['bytes']} bytes; excerpt)",
                "4",
                0.0,
                0.0,
                True,
                text,
            )
        )
    for t in tests:  # every text escaped once more: the record's, to be sure, and one line each
        t["name"] = escape(t["name"])
        t["output"] = escape(t["output"], lines=True)
    return {
        "score": points.total,
        "execution_time": max(0, round(record["wall_time_s"]["total"])),
        "output": escape(f"{record['verdict']}: {record['detail']}"),
        "output_format": "text",
        "test_output_format": "text",
        "test_name_format": "text",
        "visibility": VISIBILITY,
        "stdout_visibility": STDOUT_VISIBILITY,
        "extra_data": {"verdict": record["verdict"], "kr210_sim": _version()},
        "tests": tests,
        "leaderboard": _leaderboard(record),
    }


def _version() -> str:
    from kr210_sim.util.versions import package_version

    return package_version()


def write_results(path: Path, report: Mapping[str, Any]) -> Path:
    """Write the ``results.json`` of the one student of a grade's ``report`` to ``path``
    (atomically).

    Raises:
        ValueError: The report does not hold exactly one student (Gradescope grades one
            submission per run; ``grade --gradescope`` refuses more before grading).
        ConfigError: ``path`` cannot be written.
    """
    from kr210_sim.util.outputs import write_json_atomic

    students = report["students"]
    if len(students) != 1:
        raise ValueError(f"results.json is one submission's, the report holds {len(students)}")
    write_json_atomic(path, results(students[0], report["config"]))
    return path
