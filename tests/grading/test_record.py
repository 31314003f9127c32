"""A student's record: sealed on its way back, checked before the leaderboard reads it, and
printable whatever bytes a name holds (grading/record.py)."""

from __future__ import annotations

import copy
import hashlib
import hmac
import json
import os
import struct
from typing import Any

import numpy as np
import pytest

from kr210_sim.grading.leaderboard import build_report, page, student_line, table
from kr210_sim.grading.record import (
    blank_record,
    clean,
    printable,
    record_problem,
    seal,
    unseal,
)

KEY = bytes(range(32))


def _good() -> dict[str, Any]:
    r = blank_record("amy", "amy.py:solve", "fail", "ik-check 80/85 cases")
    r["ik_check"] = {
        "cases": 85,
        "passed": 80,
        "max_position_error_m": 0.054,
        "max_orientation_error_rad": None,
        "outside_limits": 0,
        "raised": 1,
        "returned_none": 0,
        "branch_changes": 0,
        "wall_time_per_call_s": 3e-4,
    }
    failed = {"cycle": 1, "slot": 4, "reason": "ik_failed", "detail": None, "replay": "x"}
    r["run"] = {"cycles": 2, "cycles_run": 2, "successes": 1, "failed_cycles": [failed]}
    r["diagnosis"] = [{"code": "offset_0054", "text": "54 mm off"}]
    r["plots"] = {"a.png": "iVBORw0KGgo+/="}
    return r


def test_a_sealed_record_comes_back_whole_and_nothing_else_does() -> None:
    record = _good()
    frame = seal(record, KEY)
    assert unseal(frame, KEY) == (record, "")
    forged = seal(dict(record, verdict="pass"), bytes(32))  # a record sealed without the key
    cases = {
        b"": "it sent no record",
        frame[:20]: "its record is cut short (20 bytes)",
        frame + b"}": f"{len(frame) + 1} bytes came over its record pipe, not one record",
        forged + frame: f"{len(forged) + len(frame)} bytes came over its record pipe",
        frame[:-1] + bytes([frame[-1] ^ 1]): "does not carry the grader's seal",
        forged: "does not carry the grader's seal",
        seal([], KEY): "its record is a JSON list, not an object",  # type: ignore[arg-type]
    }
    for data, why in cases.items():
        got, text = unseal(data, KEY)
        assert got is None and why in text, (data[:30], text)
    for data in (b'{"x": NaN}', b'{"x": 1', b"[" * 100_000):  # sealed with the key, bad JSON
        frame = struct.pack("!Q", len(data)) + data + hmac.new(KEY, data, hashlib.sha256).digest()
        got, text = unseal(frame, KEY)
        assert got is None and text.startswith("its record is not JSON"), text
    with pytest.raises(ValueError):
        seal({"x": float("nan")}, KEY)


def _mutations(record: dict[str, Any]) -> list[tuple[str, dict[str, Any]]]:
    """The record with one value at a time replaced by a wrong one (or its key removed)."""
    wrong: list[Any] = [None, "x", -1, 1.5, True, [], {}, float("inf"), "<script>"]
    out = []

    def walk(node: Any, path: tuple[Any, ...]) -> None:
        items = node.items() if isinstance(node, dict) else enumerate(node)
        for key, value in list(items):
            for w in [*wrong, "missing"]:
                r = copy.deepcopy(record)
                target = r
                for p in path:
                    target = target[p]
                if w != "missing":
                    target[key] = w
                elif isinstance(target, dict):
                    del target[key]
                else:
                    continue
                out.append((f"{(*path, key)} = {w!r}", r))
            if isinstance(value, dict | list):
                walk(value, (*path, key))

    walk(record, ())
    return out


def test_a_record_the_check_lets_through_never_breaks_the_leaderboard() -> None:
    """Every single wrong value is either refused with a reason or shown: the table, the line
    and the page are made for each (seeded over some 600 mutations of one record)."""
    refused = 0
    config = {"cases": 1, "cycles": 2, "seed": 0, "timeout_s": 1.0, "ik_timeout_s": 1.0}
    config |= {"memory_mb": 256, "min_success": 0.8}
    mutations = _mutations(_good())
    assert len(mutations) > 300
    for what, r in mutations:
        try:
            json.dumps(r, allow_nan=False)
        except ValueError:  # NaN or inf: unseal refuses such JSON before any check
            refused += 1
            continue
        problem = record_problem(r)
        if problem:
            refused += 1
            assert len(problem.splitlines()) == 1
            continue
        r["name"], r["spec"] = "amy", None  # the grader sets these three, as _Pool does
        r["wall_time_s"]["total"] = 1.0
        report = build_report([r], config, 1, 1.0, None)
        student_line(r)
        table(report)
        html = page(report, [r])
        assert "<script>" not in html, what
        json.dumps(report, allow_nan=False)
    assert 0 < refused < len(mutations)
    assert record_problem(_good()) == ""
    inf = copy.deepcopy(_good())
    inf["ik_check"]["max_position_error_m"] = float("inf")
    assert record_problem(inf) == "ik_check['max_position_error_m'] is float inf"
    assert "its verdict 'best' is none of pass" in record_problem(dict(_good(), verdict="best"))
    bad_plot = dict(_good(), plots={"a.png": '"><script>x</script>'})
    assert record_problem(bad_plot) == "its plots are not PNG files in base64"


def test_names_and_texts_become_printable_text() -> None:
    raw = os.fsdecode(b"bad\xffname")
    assert printable(raw) == "bad\\xffname"
    assert printable("a\nb\tc\u202ed", name=True) == "a\\nb\\tc\\u202ed"
    assert printable("a\nb") == "a\nb"  # texts keep their lines
    assert printable("caf\u00e9 \u2713") == "caf\u00e9 \u2713"
    assert printable("\ud800x") == "\\ud800x"  # a lone surrogate from JSON, not from a byte
    tree = clean({raw: [raw, {"k": raw}], "n": 1.5, "none": None})
    assert tree == {"bad\\xffname": ["bad\\xffname", {"k": "bad\\xffname"}], "n": 1.5, "none": None}
    json.dumps(tree).encode("utf-8")  # strict UTF-8 now
    rng = np.random.default_rng(0)  # random bytes as file names: always printable, one line
    for _ in range(500):
        name = os.fsdecode(bytes(rng.integers(1, 256, size=12, dtype=np.uint8)).replace(b"/", b"-"))
        shown = printable(name, name=True)
        shown.encode("utf-8")
        assert shown.isprintable() and len(shown.splitlines()) == 1


def test_a_record_s_texts_reach_no_terminal_raw() -> None:
    """An exception text with terminal escapes (cursor up, erase line, OSC title, OSC 52
    clipboard) went into the record, the line printed as a student ends and the table as it
    came (REDTEAM-4 finding 6)."""
    evil = "\x1b[1A\x1b[2K\rcid pass\x1b]0;owned\x07\x1b]52;c;ZXZpbA==\x07\x9b2J\u202e"
    r = _good()
    r["detail"] = f"raised ValueError: {evil}"
    r["diagnosis"] = [{"code": "raised", "text": f"first {evil}"}, {"code": "x", "text": evil}]
    r["output"] = {"bytes": 9, "stdout": f"line 1\n{evil}\tend\n", "stderr": ""}
    kept = clean(r)
    assert kept["detail"] == (
        "raised ValueError: \\x1b[1A\\x1b[2K\\rcid pass\\x1b]0;owned\\x07"
        "\\x1b]52;c;ZXZpbA==\\x07\\x9b2J\\u202e"
    )
    assert (
        kept["output"]["stdout"].startswith("line 1\n\\x1b[1A")
        and "\tend\n" in r["output"]["stdout"]
    )
    report = build_report([dict(r, name=f"eve{evil}")], {}, 1, 1.0, None)  # even uncleaned
    for shown in (student_line(r), table(report), student_line(kept)):
        assert all(c.isprintable() or c == "\n" for c in shown), repr(shown)
        assert "\\x1b]52;c;ZXZpbA==\\x07" in shown
    assert table(report).count("\\x1b]52") == 2  # both findings (and the name, cut short)
    assert "  eve\\x1b[1A\\x1b[2K\\rcid pass\\x1b]0;own... fail " in table(report)
