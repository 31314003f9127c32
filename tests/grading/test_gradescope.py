"""Gradescope's ``results.json`` (grading/gradescope.py), checked against a JSON Schema written
from Gradescope's *Autograder Specifications* (its "Output format": the fields, their types and
the values it names); and ``examples/gradescope/run_autograder`` grading one submission laid
out as Gradescope lays it out, for real, in the jail."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import jsonschema
import pytest
from test_leaderboard import CONFIG, _record

from kr210_sim.grading.gradescope import results, write_results
from kr210_sim.grading.leaderboard import build_report
from kr210_sim.grading.record import clean

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "ik_dh.py"
AUTOGRADER = ROOT / "examples" / "gradescope"

#: Visibility settings the specification names.
VISIBILITY = {"enum": ["hidden", "after_due_date", "after_published", "visible"]}
#: Output formats the specification names (``output_format``, ``*_format``).
FORMAT = {"enum": ["text", "html", "simple_format", "md", "ansi"]}
#: Gradescope's results.json (Autograder Specifications, "Output format"): a score at the top or
#: on every test; tests with score, max_score, status, name, number, output, tags, visibility,
#: extra_data; a leaderboard of name / value / order entries.
SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "type": "object",
    "properties": {
        "score": {"type": "number"},
        "execution_time": {"type": "number", "minimum": 0},
        "output": {"type": "string"},
        "output_format": FORMAT,
        "test_output_format": FORMAT,
        "test_name_format": FORMAT,
        "visibility": VISIBILITY,
        "stdout_visibility": VISIBILITY,
        "extra_data": {"type": "object"},
        "tests": {
            "type": "array",
            "items": {
                "type": "object",
                "properties": {
                    "score": {"type": "number"},
                    "max_score": {"type": "number"},
                    "status": {"enum": ["passed", "failed"]},
                    "name": {"type": "string"},
                    "name_format": FORMAT,
                    "number": {"type": "string"},
                    "output": {"type": "string"},
                    "output_format": FORMAT,
                    "tags": {"type": "array", "items": {"type": "string"}},
                    "visibility": VISIBILITY,
                    "extra_data": {"type": "object"},
                },
                "additionalProperties": False,
            },
        },
        "leaderboard": {
            "type": "array",
            "items": {
                "type": "object",
                "properties": {
                    "name": {"type": "string"},
                    "value": {"type": ["number", "string"]},
                    "order": {"enum": ["asc", "desc"]},
                },
                "required": ["name", "value"],
                "additionalProperties": False,
            },
        },
    },
    "additionalProperties": False,
    # "score: optional, but required if not on each test case"
    "anyOf": [
        {"required": ["score"]},
        {"required": ["tests"], "properties": {"tests": {"items": {"required": ["score"]}}}},
    ],
}


def check(results_json: dict[str, Any]) -> None:
    """``results_json`` is what Gradescope reads, and JSON all the way (no NaN)."""
    jsonschema.validate(results_json, SCHEMA, format_checker=jsonschema.FormatChecker())
    json.dumps(results_json, allow_nan=False)


def test_the_schema_refuses_what_gradescope_would() -> None:
    """The schema can fail: a test cannot pass a schema that takes anything."""
    good = results(_record("amy", "pass", 2, 85), CONFIG)
    check(good)
    bad = [
        {k: v for k, v in good.items() if k != "score"} | {"tests": [{"name": "no score"}]},
        good | {"visibility": "public"},
        good | {"tests": [{"score": 1, "status": "ok"}]},
        good | {"leaderboard": [{"name": "x", "value": None}]},
        good | {"execution_time": "136"},
        good | {"score_total": 1},
    ]
    for results_json in bad:
        with pytest.raises(jsonschema.ValidationError):
            check(results_json)


def test_every_verdict_gives_results_gradescope_reads() -> None:
    for verdict, cycles, cases in [
        ("pass", 2, 85),
        ("fail", 1, 80),
        ("fail", 0, 0),
        ("timeout", None, None),
        ("crashed", None, None),
        ("error", None, None),
    ]:
        record = _record("amy", verdict, cycles, cases)
        got = results(record, CONFIG)
        check(got)
        tests = {t["number"]: t for t in got["tests"]}
        assert got["score"] == sum(t["score"] for t in got["tests"])
        assert got["extra_data"]["verdict"] == verdict
        assert got["stdout_visibility"] == "hidden" and got["visibility"] == "visible"
        assert all(t["visibility"] == "visible" for t in got["tests"])
        assert (tests["1"]["max_score"], tests["2"]["max_score"]) == (50.0, 50.0)
        assert tests["3"]["output"] == "- amy is 54 mm off"  # every finding
        assert tests["4"]["output"] == "<hi>"  # the student's own output, as text
        if verdict == "pass":
            assert got["score"] == 100.0
            assert tests["1"]["status"] == tests["2"]["status"] == "passed"
        elif cases is None:
            assert got["score"] == 0.0 and tests["1"]["output"] == "not checked: amy detail"
    fail = results(_record("bea", "fail", 1, 80, 0.054), CONFIG)
    assert fail["score"] == 72.06 and fail["output"] == "fail: bea detail"
    assert fail["tests"][1]["output"] == (
        "1 of 2 cycles succeeded (pass bar 2)\ncycle 2 (slot 4): ik_failed: a <b> & c"
    )
    assert {e["name"]: e["value"] for e in fail["leaderboard"]} == {
        "ik-check cases passed": 80,
        "cycles succeeded": 1,
        "worst position error [mm]": 54.0,
        "time per IK call [ms]": 0.3,
    }


def test_a_hostile_student_s_texts_are_inert_in_results_json(tmp_path: Path) -> None:
    evil = "\x1b[1A\x1b[2K\r\x1b]52;c;ZXZpbA==\x07\u202e"
    r = _record(f"eve{evil}", "fail", 1, 80)
    r["detail"] = r["diagnosis"][0]["text"] = r["run"]["failed_cycles"][0]["detail"] = evil
    r["output"]["stdout"] = f"{evil}\n"
    report = build_report([clean(r)], CONFIG, 1, 1.0, None)
    path = write_results(tmp_path / "results.json", report)
    got = json.loads(path.read_text())
    check(got)
    texts = [got["output"]] + [t[k] for t in got["tests"] for k in ("name", "output")]
    assert all(c.isprintable() or c in "\n\t" for text in texts for c in text)
    assert all("\\x1b]52;c;ZXZpbA==\\x07" in got["tests"][i]["output"] for i in (1, 2, 3))
    with pytest.raises(ValueError, match="report holds 2"):
        write_results(tmp_path / "two.json", build_report([r, r], CONFIG, 1, 1.0, None))


# -- run_autograder, on submissions laid out as Gradescope lays them out -------------------------
def _autograder(tmp_path: Path, files: dict[str, str]) -> tuple[subprocess.CompletedProcess, Path]:
    """A Gradescope container's folders in ``tmp_path``: ``source`` (the zip: run_autograder
    and setup.sh), ``submission`` (``files``), ``results``; run_autograder run in it."""
    home = tmp_path / "autograder"
    shutil.copytree(AUTOGRADER, home / "source")
    shutil.copy2(home / "source" / "run_autograder", home / "run_autograder")
    for name, text in files.items():
        (home / "submission" / name).parent.mkdir(parents=True, exist_ok=True)
        (home / "submission" / name).write_text(text)
    env = dict(
        os.environ,
        AUTOGRADER=str(home),
        KR210_PYTHON=sys.executable,
        KR210_GRADE_OPTIONS="--cases 0 --cycles 1 --workers 1",
        PYTHONPATH=str(ROOT),
        TMPDIR=str(tmp_path),
    )
    done = subprocess.run(
        [str(home / "run_autograder")],
        cwd=home,
        env=env,
        capture_output=True,
        text=True,
        timeout=900,
    )
    return done, home / "results" / "results.json"


@pytest.mark.slow
@pytest.mark.usefixtures("jail_ok")
def test_run_autograder_grades_a_submission_folder_as_gradescope_lays_it_out(
    tmp_path: Path,
) -> None:
    """An honest ``ik.py`` beside a helper module (one student, not two), a submission whose
    IK raises terminal escapes, and an original-form repository (``kuka_arm/scripts/
    IK_server.py``): each gives a results.json Gradescope reads."""
    src = EXAMPLE.read_text()
    done, path = _autograder(tmp_path / "a", {"ik.py": src, "notes.py": "X = 1\n"})
    assert done.returncode == 0, done.stderr
    got = json.loads(path.read_text())
    check(got)
    assert got["score"] == 100.0 and got["extra_data"]["verdict"] == "pass"
    assert [t["status"] for t in got["tests"][:2]] == ["passed", "passed"]
    assert not list((tmp_path / "a").glob("tmp*"))  # its working folder removed
    evil = "\x1b[1A\x1b[2K\x1b]52;c;ZXZpbA==\x07"
    hostile = f"def solve(T, q):\n    print({evil!r})\n    raise ValueError({evil!r})\n"
    done, path = _autograder(tmp_path / "b", {"ik.py": hostile})
    assert done.returncode == 0, done.stderr
    raw = path.read_text()
    got = json.loads(raw)
    check(got)
    assert got["score"] == 0.0 and got["extra_data"]["verdict"] == "fail"
    assert "\\\\x1b]52;c;ZXZpbA==\\\\x07" in raw  # said as visible escapes, in JSON
    assert "\x1b" not in done.stdout + done.stderr
    from ros_class import numpy_server  # the original exercise's form: a repository

    repo = {"kuka_arm/scripts/IK_server.py": numpy_server(), "README.md": "# pick and place\n"}
    done, path = _autograder(tmp_path / "c", repo)
    assert done.returncode == 0, done.stderr
    got = json.loads(path.read_text())
    check(got)
    assert got["extra_data"]["verdict"] == "pass", got["output"]


def test_run_autograder_says_why_when_there_is_no_submission(tmp_path: Path) -> None:
    home = tmp_path / "autograder"
    home.mkdir()
    env = dict(os.environ, AUTOGRADER="autograder", KR210_PYTHON=sys.executable)  # relative
    done = subprocess.run(
        [str(AUTOGRADER / "run_autograder")],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2
    assert done.stderr == f"run_autograder: no submission folder {home}/submission\n"
