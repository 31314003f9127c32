"""A class's verdicts for a gradebook (grading/gradebook.py): the score of each verdict, and a
CSV that an LMS imports and no spreadsheet runs."""

from __future__ import annotations

import csv
import io
from pathlib import Path
from typing import Any

import pytest
from test_leaderboard import CONFIG, _record

from kr210_sim.grading.gradebook import (
    CSV_COLUMNS,
    POINTS,
    Score,
    csv_cell,
    gradebook_csv,
    score,
    write_gradebook,
)
from kr210_sim.grading.leaderboard import build_report
from kr210_sim.grading.record import clean


def test_a_pass_has_every_point_and_other_verdicts_the_share_their_figures_earned() -> None:
    assert score(_record("amy", "pass", 2, 85), 0.8).total == POINTS
    half = _record("bea", "fail", 1, 85)  # every case, 1 of a pass bar of 2 cycles
    assert score(half, 0.8) == Score(50.0, 25.0)
    assert score(_record("cid", "fail", 0, 17), 0.8) == Score(10.0, 0.0)
    assert score(_record("dan", "fail", 2, 0), 0.5) == Score(0.0, 50.0)  # bar 1: reached
    for verdict in ("timeout", "crashed", "error"):  # no figures: nothing earned
        assert score(_record("eve", verdict, None, None), 0.8).total == 0.0
    with pytest.raises(ValueError, match="score out of range"):
        Score(51.0, 0.0)


#: Cells a spreadsheet would run as formulas.
FORMULAS = (
    '=HYPERLINK("http://x/?"&A1,"grade")',
    "+1+cmd|' /C calc'!A0",
    "-2+3",
    "@SUM(1+1)*cmd|' /C calc'!A0",
    "\t=1+1",
    "\r=1+1",
)


def test_a_cell_that_starts_as_a_formula_is_text() -> None:
    for text in FORMULAS:
        cell = csv_cell(text)
        assert cell.isprintable() and cell[0] not in "=+-@", cell
        assert cell.startswith("\\" if text[0] in "\t\r" else "'"), cell  # \t, \r: visible
    assert csv_cell("--x") == "'--x"
    assert csv_cell("amy") == "amy" and csv_cell("a=b") == "a=b"
    assert csv_cell("a\nb\x1b]52;c;eA==\x07") == "a\\nb\\x1b]52;c;eA==\\x07"


def test_the_csv_has_a_row_per_student_in_order_and_every_hostile_cell_neutralised(
    tmp_path: Path,
) -> None:
    records: list[dict[str, Any]] = []
    for i, text in enumerate(FORMULAS):
        r = _record(text, "fail", 1, 80, i / 1000)
        r["detail"] = text
        r["diagnosis"] = [{"code": "a", "text": text}, {"code": "b", "text": 'two, "quoted"'}]
        records.append(clean(r))
    records.append(_record("cid", "pass", 2, 85))
    report = build_report(records, CONFIG, 1, 1.0, None)
    path = write_gradebook(tmp_path / "grades.csv", report)
    text = path.read_bytes().decode("utf-8")
    assert text == gradebook_csv(report)
    rows = list(csv.reader(io.StringIO(text, newline="")))
    assert tuple(rows[0]) == CSV_COLUMNS
    assert [r[0] for r in rows[1:]] == [csv_cell(s["name"]) for s in report["students"]]
    assert rows[1] == ["cid", "pass", "100.00", "100", "cid detail", "cid is 54 mm off"]
    for row in rows[2:]:
        assert row[1:4] == ["fail", "72.06", "100"]  # 80/85 cases, 1 of 2 cycles
        for cell in (row[0], row[4], row[5]):
            assert cell[0] in "'\\" and cell.isprintable(), cell
        assert row[5].endswith(' | two, "quoted"')
