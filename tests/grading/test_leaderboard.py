"""The leaderboard's order, table, report and page (grading/leaderboard.py), and the page in a real
headless Chromium with hostile names and texts: it renders, no script runs, every student is
there."""

from __future__ import annotations

import base64
import io
import json
import os
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from kr210_sim.grading.leaderboard import build_report, page, ranked, table, write_html
from kr210_sim.grading.record import clean

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
    assert html.count(f"data:image/png;base64,{PNG}") == 4  # those who answered
    assert "a &lt;b&gt; &amp; c" in html and "&lt;hi&gt;" in html
    assert "http" not in html and "<script" not in html and "<link" not in html
    assert html.index("<h2>cid ") < html.index("<h2>zed ")
    assert html.index('href="#student-1">cid<') < html.index('id="student-1"')
    path = write_html(tmp_path / "board.html", report, with_plots)
    assert path.read_text() == html


def test_the_terminal_names_every_finding_of_a_student_who_did_not_pass() -> None:
    """Only the first finding was shown."""
    r = _record("gus", "fail", 1, 80, 0.054)
    r["diagnosis"].append({"code": "wrist_flip", "text": "gus flips its wrist"})
    lines = table(build_report([r], CONFIG, 1, 1.0, None)).splitlines()
    assert [ln.strip() for ln in lines[2:4]] == ["gus is 54 mm off", "gus flips its wrist"]
    crashed = dict(_record("hal", "crashed", None, None), diagnosis=[])
    assert table(build_report([crashed], CONFIG, 1, 1.0, None)).splitlines()[2].strip() == (
        "hal detail"
    )


def test_the_page_s_top_table_has_each_student_s_diagnosis() -> None:
    r = _record("gus", "fail", 1, 80, 0.054)
    r["diagnosis"].append({"code": "long", "text": "<b>" + "x" * 300})
    ok = dict(_record("ida", "pass", 2, 85), diagnosis=[])
    crashed = dict(_record("hal", "crashed", None, None), diagnosis=[])
    html = page(build_report([r, ok, crashed], CONFIG, 1, 1.0, None), [r, ok, crashed])
    head, rows = html.split("</tr>", 1)[0], html.split("</table>")[0].split("</tr>")[1:-1]
    assert head.endswith('<th class="l">diagnosis</th>')
    cells = [row.rsplit('<td class="l d">', 1)[1].removesuffix("</td>") for row in rows]
    assert cells[0] == ""  # ida passed, nothing to say
    assert cells[1].startswith("gus is 54 mm off<br>&lt;b&gt;xxx") and cells[1].endswith("x...")
    assert cells[2] == "hal detail"  # no diagnosis: the detail says why


def test_no_plots_for_a_student_who_never_answered() -> None:
    """A student whose every call raised or returned None had two empty plots on the page."""
    silent = _record("gus", "fail", 0, 0)
    silent["ik_check"] |= {"raised": 85, "max_position_error_m": None}
    silent["ik_check"]["max_orientation_error_rad"] = None
    silent["plots"] = {"ik_error_histograms.png": PNG, "ik_error_workspace.png": PNG}
    answered = dict(_record("amy", "fail", 1, 80, 0.01), plots=dict(silent["plots"]))
    html = page(build_report([silent, answered], CONFIG, 1, 1.0, None), [silent, answered])
    gus = html[html.index("<h2>gus ") :]
    amy = html[html.index("<h2>amy ") : html.index("<h2>gus ")]
    assert "<img" not in gus and "No error plots: it answered none of the cases." in gus
    assert amy.count("<img") == 2


def test_the_cycles_column_reads_successes_of_the_cycles_asked_for() -> None:
    stopped = _record("gus", "timeout", 0, 85)
    stopped["run"] |= {"cycles": 10, "cycles_run": 7, "successes": 7}
    report = build_report([stopped], CONFIG, 1, 1.0, None)
    assert table(report).splitlines()[1].split()[6] == "7/10"
    assert "run: 7/10 cycles succeeded (stopped after 7)" in page(report, [stopped])


# -- in a real browser -----------------------------------------------------------------------
#: Hostile texts: markup that would run a script or load something, were it not escaped.
HOSTILE = (
    "<script>window.pwned=1</script>",
    '"><img src=x onerror="window.pwned=2">',
    "'><svg onload=window.pwned=3>",
    "$(touch pwned) `touch pwned2`",
    "</pre></section><iframe src=javascript:window.pwned=4>",
    os.fsdecode(b"bad\xffname \xc3\x28"),  # not UTF-8: a file name's bytes
    "long" * 1250,
)


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    from chromium import Chromium, find_chromium

    if find_chromium() is None:
        why = "no Chromium here (bash .ci/run installs chromium-headless-shell)"
        if os.environ.get("KR210_REQUIRE_CHROMIUM"):
            pytest.fail(why, pytrace=False)
        pytest.skip(why)
    with Chromium(width=1000, height=700, timeout=60) as c:
        yield c


def page_in_browser(browser: Any, path: Path) -> dict[str, Any]:
    """Load the leaderboard page ``path`` in Chromium; what it shows and what ran in it."""
    browser.open(path.resolve().as_uri())
    deadline = time.monotonic() + 30
    while browser.evaluate("document.readyState") != "complete":
        assert time.monotonic() < deadline, "the page did not load"
        time.sleep(0.05)
    found = browser.evaluate(
        """JSON.stringify({
          title: document.title,
          pwned: typeof window.pwned,
          scripts: document.scripts.length,
          active: document.querySelectorAll(
            '[onerror],[onload],[onclick],iframe,object,embed,svg,link,base,meta[http-equiv]'
          ).length,
          rows: [...document.querySelectorAll('table tr')].slice(1).map(
            tr => tr.querySelector('td:nth-child(2)').textContent),
          links: [...document.querySelectorAll('a')].map(a => a.getAttribute('href')),
          sections: [...document.querySelectorAll('section h2')].map(
            h => h.firstChild.textContent.trim()),
          images: [...document.images].map(i => i.src.slice(0, 22)),
          text: document.body.innerText,
        })"""
    )
    from PIL import Image

    shot = np.asarray(Image.open(io.BytesIO(browser.screenshot())).convert("RGB"))
    result: dict[str, Any] = json.loads(found)
    result["screenshot_std"] = float(shot.std())
    return result


def check_page(shown: dict[str, Any], names: list[str]) -> None:
    """The page rendered, ran nothing, and lists ``names`` (in order) in the table and the
    sections."""
    assert shown["title"] == "kr210_sim grade"
    assert shown["pwned"] == "undefined" and shown["scripts"] == 0 and shown["active"] == 0
    assert shown["rows"] == names and shown["sections"] == names
    assert all(h.startswith("#student-") for h in shown["links"])
    assert all(src == "data:image/png;base64," for src in shown["images"])
    assert shown["screenshot_std"] > 5  # not a blank page


@pytest.mark.slow
def test_the_page_shows_hostile_names_and_texts_as_text(browser: Any, tmp_path: Path) -> None:
    records = []
    for i, text in enumerate(HOSTILE):
        r = _record(text, "fail", 1, 80)
        r["detail"] = text
        r["diagnosis"] = [{"code": "x", "text": text}]
        r["output"] = {"bytes": 10, "stdout": text, "stderr": text}
        r["run"]["failed_cycles"][0] |= {"detail": text, "replay": text, "reason": text}
        r["ik_check"]["max_position_error_m"] = i / 1000  # the rank: HOSTILE's order
        records.append(clean(r))  # as the grader keeps every record
    report = build_report(records, CONFIG, 1, 1.0, None)
    path = write_html(tmp_path / "board.html", report, records)
    path.read_bytes().decode("utf-8")  # strict UTF-8
    shown = page_in_browser(browser, path)
    names = [r["name"] for r in records]
    check_page(shown, names)
    assert "bad\\xffname \\xc3(" in names[5]
    for text in names[:5]:  # every hostile text is on the page as text, where it was put
        assert shown["text"].count(text) >= 6, text
    assert not (tmp_path / "pwned").exists()


# -- a hostile student, graded for real in the jail --------------------------------------------
@pytest.mark.slow
@pytest.mark.usefixtures("jail_ok")
def test_a_hostile_student_s_escapes_reach_no_terminal_page_or_gradebook(tmp_path: Path) -> None:
    """An IK that prints and raises terminal escapes (cursor up, erase line and a fake
    ``pass`` row, the window title, an OSC 52 clipboard write, a C1 CSI, a bidi override): its
    text reached the instructor's terminal raw, in the line printed as it ended and in the
    table (REDTEAM-4 finding 6)."""
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[2]
    evil = "\x1b[1A\x1b[2K\r  1  honest  pass\x1b]0;owned\x07\x1b]52;c;ZXZpbA==\x07\x9b2J\u202e"
    folder = tmp_path / "class"
    folder.mkdir()
    (folder / "honest.py").write_text((root / "examples" / "ik_dh.py").read_text())
    body = f"def solve(T, q):\n    print({evil!r})\n    raise ValueError({evil!r})\n"
    (folder / "evil.py").write_text(f"print({evil!r})\n\n{body}")
    out = tmp_path / "out"
    args = ["class", "--cases", "0", "--cycles", "1", "--workers", "2"]
    args += ["--report", str(out / "grade.json"), "--html", str(out / "grade.html")]
    args += ["--csv", str(out / "grades.csv")]
    done = subprocess.run(
        [sys.executable, "-m", "kr210_sim", "grade", *args],
        cwd=tmp_path,
        env=dict(os.environ, PYTHONPATH=str(root), TMPDIR=str(tmp_path)),
        capture_output=True,
        timeout=900,
    )
    assert done.returncode == 1, done.stderr
    report = json.loads((out / "grade.json").read_text())
    assert {s["name"]: s["verdict"] for s in report["students"]} == {
        "honest": "pass",
        "evil": "fail",
    }
    seen = rb"\x1b]52;c;ZXZpbA==\x07"
    raw = (b"\x1b", b"\x07", b"\r", "\x9b".encode(), "\u202e".encode())
    for name, data in [
        ("console", done.stdout + done.stderr),
        ("page", (out / "grade.html").read_bytes()),
        ("gradebook", (out / "grades.csv").read_bytes().replace(b"\r\n", b"\n")),
    ]:
        assert [b for b in raw if b in data] == [], name
        assert seen in data, name  # said, as visible escapes
    assert rb"raised on 68 poses (e.g. IK_debug case 1: ValueError: \x1b[1A\x1b[2K" in done.stdout
