"""A class's verdicts for a course's gradebook: each student's score, and the CSV
(``grade --csv``) an LMS imports.

The score is out of :data:`POINTS`: :data:`IK_POINTS` for the ik-check and :data:`RUN_POINTS`
for the run (:func:`score`). A ``pass`` has them all; any other verdict has the share of each
that its figures earned: the cases passed of the cases tried, the cycles that succeeded of the
run's pass bar (reaching the bar earns the run's points). A student graded no further than an
error, a crash or a timeout before its figures has none. The same score is what
:mod:`~kr210_sim.grading.gradescope` hands Gradescope.

The CSV has a row per student, in the leaderboard's order, with the columns of
:data:`CSV_COLUMNS`. Every text in it came from, or quotes, a student, and a spreadsheet reads a
cell that starts with ``=``, ``+``, ``-`` or ``@`` as a formula (CSV injection: a name
``=HYPERLINK(...)`` runs when the instructor opens the file): such a cell is written with a
leading ``'``, which every spreadsheet reads as "this is text" (:func:`csv_cell`). Control
characters are escaped (:func:`~kr210_sim.util.console.escape`), so each cell is one line.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from kr210_sim.util.console import escape

#: Points of the whole grade.
POINTS = 100.0
#: Points of the ik-check ...
IK_POINTS = 50.0
#: ... and of the run.
RUN_POINTS = POINTS - IK_POINTS
#: The CSV's columns.
CSV_COLUMNS = ("student", "verdict", "score", "out_of", "detail", "diagnosis")
#: First characters a spreadsheet reads as the start of a formula (a leading tab or carriage
#: return, which some trim first, is escaped to ``\\t`` / ``\\r`` before this is looked at).
FORMULA_STARTS = ("=", "+", "-", "@")
#: Between two findings of one diagnosis in one CSV cell.
FINDING_SEPARATOR = " | "


@dataclass(frozen=True, slots=True)
class Score:
    """A student's score [points], by part.

    Attributes:
        ik_check: Of :data:`IK_POINTS`.
        run: Of :data:`RUN_POINTS`.
    """

    ik_check: float
    run: float

    def __post_init__(self) -> None:
        if not (0 <= self.ik_check <= IK_POINTS and 0 <= self.run <= RUN_POINTS):
            raise ValueError(f"score out of range: {self.ik_check}, {self.run}")

    @property
    def total(self) -> float:
        """Of :data:`POINTS`, to 0.01."""
        return round(self.ik_check + self.run, 2)


def pass_bar(run: Mapping[str, Any], min_success: float) -> int:
    """Cycles of ``run`` that must succeed (its ``cycles`` asked for, at ``min_success``)."""
    return math.ceil(min_success * run["cycles"] - 1e-9)


def score(record: Mapping[str, Any], min_success: float) -> Score:
    """The score of ``record`` (see the module doc).

    Args:
        record: A checked record (:func:`~kr210_sim.grading.record.record_problem`).
        min_success: The run's pass bar (share of its cycles), as graded.
    """
    if record["verdict"] == "pass":
        return Score(IK_POINTS, RUN_POINTS)
    ik, run = record.get("ik_check"), record.get("run")
    ik_points = 0.0
    if ik and ik["cases"]:
        ik_points = round(IK_POINTS * min(1.0, ik["passed"] / ik["cases"]), 2)
    run_points = 0.0
    if run:
        need = pass_bar(run, min_success)
        share = 1.0 if need <= 0 else min(1.0, run["successes"] / need)
        run_points = round(RUN_POINTS * share, 2)
    return Score(ik_points, run_points)


def csv_cell(text: str) -> str:
    """``text`` as a CSV cell no spreadsheet runs: escaped to one line, and with a leading
    ``'`` when it starts as a formula would (:data:`FORMULA_STARTS`)."""
    cell = escape(text)
    return "'" + cell if cell.startswith(FORMULA_STARTS) else cell


def diagnosis_text(record: Mapping[str, Any]) -> str:
    """Every finding of ``record``'s diagnosis, in order, joined by :data:`FINDING_SEPARATOR`."""
    return FINDING_SEPARATOR.join(f["text"] for f in record.get("diagnosis") or [])


def gradebook_csv(report: Mapping[str, Any]) -> str:
    """The CSV of a grade's ``report`` (see the module doc), with a header row."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\r\n")  # RFC 4180
    writer.writerow(CSV_COLUMNS)
    min_success = report["config"]["min_success"]
    for r in report["students"]:
        writer.writerow(
            [
                csv_cell(r["name"]),
                csv_cell(r["verdict"]),
                f"{score(r, min_success).total:.2f}",
                f"{POINTS:.0f}",
                csv_cell(r["detail"]),
                csv_cell(diagnosis_text(r)),
            ]
        )
    return buffer.getvalue()


def write_gradebook(path: Path, report: Mapping[str, Any]) -> Path:
    """Write :func:`gradebook_csv` to ``path`` atomically (UTF-8).

    Raises:
        ConfigError: ``path`` cannot be written.
    """
    from kr210_sim.util.outputs import write_text_atomic

    return write_text_atomic(path, gradebook_csv(report))
