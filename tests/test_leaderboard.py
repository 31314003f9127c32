"""The leaderboard's order, table, report and page (eval/leaderboard.py)."""

from __future__ import annotations

import base64
import json
from pathlib import Path
from typing import Any

from kr210_sim.eval.leaderboard import build_report, page, ranked, table, write_html

PNG = base64.b64encode(b"\x89PNG\r\n\x1a\nnot really").decode()


def _record(name: str, verdict: str, cycles: int | None, cases: int | None, worst: float = 0.0):
    ik = None
    if cases is not None:
        ik = {
            "cases": 85,
            "passed": cases,
            "max_position_error_m": worst,
            "max_orientation_error_rad": 0.0,
            "outside_limits": 0,
            "raised": 0,
            "returned_none": 0,
            "branch_changes": 0,
            "wall_time_per_call_s": 3e-4,
        }
    run = None
    if cycles is not None:
        failed = [
            {"cycle": 2, "slot": 4, "reason": "ik_failed", "detail": "a <b> & c", "replay": "x"}
        ]
        run = {"cycles": 2, "successes": cycles, "failures": {}, "failed_cycles": failed}
    return {
        "name": name,
        "spec": f"{name}.py:solve",
        "verdict": verdict,
        "detail": f"{name} detail",
        "ik_check": ik,
        "run": run,
        "diagnosis": [{"code": "offset_0054", "text": f"{name} is 54 mm off"}],
        "output": {"bytes": 5, "stdout": "<hi>", "stderr": ""},
        "wall_time_s": {"ik_check": 1.0, "run": 2.0, "total": 3.5},
    }


RECORDS: list[dict[str, Any]] = [
    _record("zed", "error", None, None),
    _record("bea", "fail", 1, 80, 0.054),
    _record("amy", "fail", 1, 80, 0.01),
    _record("cid", "pass", 2, 85),
    _record("dan", "timeout", None, None),
    _record("eve", "fail", 2, 10),
    _record("fay", "crashed", None, None),
]
CONFIG = {
    "cases": 20,
    "cycles": 2,
    "seed": 0,
    "timeout_s": 120.0,
    "ik_timeout_s": 2.0,
    "memory_mb": 1024,
    "min_success": 0.8,
}


def test_order_is_verdict_then_cycles_then_cases_then_error_then_name() -> None:
    names = [r["name"] for r in ranked(RECORDS)]
    assert names == ["cid", "eve", "amy", "bea", "dan", "fay", "zed"]


def test_report_counts_verdicts_and_keeps_plots_out() -> None:
    with_plots = [dict(r, plots={"a.png": PNG}) for r in RECORDS]
    report = build_report(with_plots, CONFIG, 2, 12.5, None)
    assert report["summary"] == {
        "students": 7,
        "verdicts": {"pass": 1, "fail": 3, "timeout": 1, "crashed": 1, "error": 1},
        "all_passed": False,
    }
    assert all("plots" not in s for s in report["students"])
    assert report["interrupted_by"] is None and report["wall_execution"] == {"workers": 2}
    json.dumps(report, allow_nan=False)


def test_table_has_a_line_per_student_and_says_why_those_who_failed_did() -> None:
    text = table(build_report(RECORDS, CONFIG, 1, 1.0, None))
    lines = text.splitlines()
    assert lines[1].split() == ["1", "cid", "pass", "85/85", "0", "0", "2/2", "3.5"]
    assert lines[2].split()[:4] == ["2", "eve", "fail", "10/85"]
    assert lines[3].strip() == "eve is 54 mm off"
    assert "     54 " in lines[6]  # bea's worst position error in mm
    assert lines[-2] == "  7 students: 1 pass, 3 fail, 1 timeout, 1 crashed, 1 error"
    assert lines[-1] == "FAIL: 6 students did not pass"
    only = table(build_report(RECORDS[3:4], CONFIG, 1, 1.0, None))
    assert only.splitlines()[-1] == "PASS: all 1 students passed"


def test_page_is_self_contained_and_escaped(tmp_path: Path) -> None:
    with_plots = [dict(r, plots={"ik_error_histograms.png": PNG}) for r in RECORDS]
    report = build_report(with_plots, CONFIG, 1, 1.0, None)
    html = page(report, with_plots)
    assert html.count(f"data:image/png;base64,{PNG}") == 7
    assert "a &lt;b&gt; &amp; c" in html and "&lt;hi&gt;" in html
    assert "http" not in html and "<script" not in html and "<link" not in html
    assert html.index('id="cid"') < html.index('id="zed"')
    path = write_html(tmp_path / "board.html", report, with_plots)
    assert path.read_text() == html
