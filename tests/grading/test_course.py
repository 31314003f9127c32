"""The files grade hands a course (grading/course.py): checked before anyone is graded, written
from the report after (of the students graded, also when interrupted)."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest
from test_leaderboard import CONFIG, _record

from kr210_sim.grading.course import CourseOutputs
from kr210_sim.grading.leaderboard import build_report

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "ik_dh.py"


def test_grade_s_course_outputs_are_checked_before_anyone_is_graded(
    tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    """--gradescope is one submission's; no output may replace another or a student's file."""
    from kr210_sim.cli import main

    folder = tmp_path / "class"
    folder.mkdir()
    for name in ("amy", "bea"):
        (folder / f"{name}.py").write_text(EXAMPLE.read_text())
    report = tmp_path / "grade.json"
    for argv, message in (
        ([str(folder), "--gradescope", str(tmp_path / "r.json")], "2 students were found"),
        ([str(folder / "amy.py"), "--csv", str(report), "--report", str(report)], "--csv"),
        ([str(folder), "--csv", str(folder / "bea.py")], "student bea"),
        ([str(folder), "--csv", str(tmp_path)], "is a folder"),
    ):
        assert main(["grade", *argv, "--cases", "0", "--cycles", "1"]) == 2
        err = capsys.readouterr().err
        assert message in err and len(err.strip().splitlines()) == 1, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["class"]  # nothing graded, written


def test_what_was_asked_for_is_written_and_said(tmp_path: Path) -> None:
    course = CourseOutputs(tmp_path / "gs" / "results.json", tmp_path / "grades.csv")
    report = build_report([_record("amy", "pass", 2, 85)], CONFIG, 1, 1.0, None)
    assert course.write(report) == [
        f"gradebook: {tmp_path / 'grades.csv'}",
        f"gradescope: {tmp_path / 'gs' / 'results.json'}",
    ]
    assert json.loads((tmp_path / "gs" / "results.json").read_text())["score"] == 100.0
    rows = list(csv.reader((tmp_path / "grades.csv").open(newline="")))
    assert [r[:3] for r in rows] == [["student", "verdict", "score"], ["amy", "pass", "100.00"]]
    # Interrupted before its one student ended: a gradebook of none, no results.json.
    empty = build_report([], CONFIG, 1, 1.0, KeyboardInterrupt())
    (tmp_path / "gs" / "results.json").unlink()
    assert course.write(empty) == [f"gradebook: {tmp_path / 'grades.csv'}"]
    assert not (tmp_path / "gs" / "results.json").exists()
    assert CourseOutputs().write(report) == []
