"""A student's record: its shape, its way back from the grading process, and its check.

The grading process (:mod:`kr210_sim.grading.student`) sends its record to the grader over a pipe
that only the two of them hold, as one sealed frame (:func:`seal`): the JSON's length, the
JSON, and an HMAC-SHA256 of it under a key the grader gave that process on its standard input.
The grader takes the record only when that process exited with code 0, the bytes it read are
exactly one frame, the HMAC matches (:func:`unseal`), and the record has every field the
leaderboard reads, of the right type (:func:`record_problem`); anything else makes that student
``crashed``, with a detail that says which of these failed. Nothing the student's code can write
(a file, the grading process's output) is read for a verdict.

Names and texts are shown and written as text any terminal, JSON reader and browser takes, and
that none acts on: :func:`printable` turns the surrogate escapes Python gives undecodable bytes
of a file name into ``\\xNN`` and control characters (ESC, BEL, a bidi override; for names,
newlines and tabs too) into escapes; :func:`clean` does it for every string of a record as the
grader takes it in, so a student's exception text or output reaches no terminal, page, CSV or
``results.json`` raw. Whatever prints a record's strings to a terminal passes them through
:func:`~kr210_sim.util.console.escape` once more, one line each.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import math
import struct
from collections.abc import Callable, Mapping
from typing import Any

from kr210_sim.util.console import escape

#: The verdicts, best first (the leaderboard's order).
VERDICTS = ("pass", "fail", "timeout", "crashed", "error")
#: Frame header: the JSON's length in bytes (big-endian, 8 bytes).
_HEADER = struct.Struct("!Q")
#: Bytes of the HMAC that ends a frame (SHA-256).
_MAC_BYTES = 32
#: The largest record the grader reads [bytes] (a record with two plots is about 0.3 MB).
RECORD_LIMIT = 32 << 20
#: The longest text quoted from a record's strings in one line [characters].
LINE_LIMIT = 400


def blank_record(name: str, spec: str, verdict: str, detail: str) -> dict[str, Any]:
    """A record with no figures: for a student graded no further than ``verdict``.

    Args:
        name: The student's name (as shown).
        spec: Its SPEC ("" for none).
        verdict: One of :data:`VERDICTS`.
        detail: One line: why.
    """
    return {
        "name": name,
        "spec": spec or None,
        "verdict": verdict,
        "detail": detail,
        "ik_check": None,
        "run": None,
        "diagnosis": [],
        "output": {"bytes": 0, "stdout": "", "stderr": ""},
        "wall_time_s": {"ik_check": None, "run": None, "student": None, "total": 0.0},
    }


# -- the way back ----------------------------------------------------------------------------
def seal(record: Mapping[str, Any], key: bytes) -> bytes:
    """The frame that carries ``record`` (see the module doc).

    Raises:
        ValueError: When the record holds NaN or infinity (JSON has neither).
    """
    data = json.dumps(record, allow_nan=False).encode()
    return _HEADER.pack(len(data)) + data + hmac.new(key, data, hashlib.sha256).digest()


def _no_constant(name: str) -> float:
    raise ValueError(f"{name} is not a JSON number")


def unseal(frame: bytes, key: bytes) -> tuple[dict[str, Any] | None, str]:
    """The record a frame carries, or None and why not (one phrase).

    The frame must be exactly one :func:`seal` frame under ``key``: bytes before or after it,
    a wrong length or a wrong HMAC are refused, and so is JSON that is not an object or holds
    NaN or infinity.
    """
    if not frame:
        return None, "it sent no record"
    if len(frame) < _HEADER.size + _MAC_BYTES:
        return None, f"its record is cut short ({len(frame)} bytes)"
    (size,) = _HEADER.unpack_from(frame)
    if size != len(frame) - _HEADER.size - _MAC_BYTES:
        return None, f"{len(frame)} bytes came over its record pipe, not one record"
    data = frame[_HEADER.size : _HEADER.size + size]
    mac = frame[_HEADER.size + size :]
    if not hmac.compare_digest(mac, hmac.new(key, data, hashlib.sha256).digest()):
        return None, "its record does not carry the grader's seal"
    try:
        record = json.loads(data, parse_constant=_no_constant)
    except (ValueError, RecursionError) as exc:
        return None, f"its record is not JSON ({type(exc).__name__})"
    if not isinstance(record, dict):
        return None, f"its record is a JSON {type(record).__name__}, not an object"
    return record, ""


# -- the check -------------------------------------------------------------------------------
def _number(v: object) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def _count(v: object) -> bool:
    return isinstance(v, int) and not isinstance(v, bool) and v >= 0


def _text(v: object) -> bool:
    return isinstance(v, str)


def _number_or_none(v: object) -> bool:
    return v is None or _number(v)


def _text_or_none(v: object) -> bool:
    return v is None or isinstance(v, str)


Check = Callable[[object], bool]
#: What the leaderboard reads of each block, and what each value must be.
_IK_CHECK: dict[str, Check] = {
    "cases": _count,
    "passed": _count,
    "max_position_error_m": _number_or_none,
    "max_orientation_error_rad": _number_or_none,
    "outside_limits": _count,
    "raised": _count,
    "returned_none": _count,
    "wall_time_per_call_s": _number,
}
_RUN: dict[str, Check] = {"cycles": _count, "successes": _count}
_FAILED_CYCLE: dict[str, Check] = {
    "cycle": _count,
    "slot": _count,
    "reason": _text,
    "detail": _text_or_none,
    "replay": _text,
}
_OUTPUT: dict[str, Check] = {"bytes": _count, "stdout": _text, "stderr": _text}
_FINDING: dict[str, Check] = {"code": _text, "text": _text}


def _fields(block: object, where: str, checks: Mapping[str, Check]) -> str:
    if not isinstance(block, dict):
        return f"{where} is not an object"
    for key, ok in checks.items():
        if key not in block:
            return f"{where} has no {key!r}"
        if not ok(block[key]):
            return f"{where}[{key!r}] is {type(block[key]).__name__} {_short(block[key])}"
    return ""


def _short(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def record_problem(record: Mapping[str, Any]) -> str:
    """What makes ``record`` unusable for the leaderboard (one phrase), or "" when nothing.

    Checked: a known ``verdict``; ``detail`` a string; ``ik_check`` and ``run`` None or objects
    with the figures the table and the page show (counts whole and >= 0, errors finite);
    ``diagnosis`` a list of ``code`` / ``text`` pairs; ``output`` with byte count and texts;
    ``wall_time_s`` an object; ``plots``, when there, an object of base64 strings.
    """
    verdict = record.get("verdict")
    if verdict not in VERDICTS:
        return f"its verdict {_short(verdict)} is none of {', '.join(VERDICTS)}"
    if not isinstance(record.get("detail"), str):
        return "its detail is not a string"
    ik = record.get("ik_check")
    if ik is not None and (why := _fields(ik, "ik_check", _IK_CHECK)):
        return why
    run = record.get("run")
    if run is not None:
        if why := _fields(run, "run", _RUN):
            return why
        if not _count(run.get("cycles_run", 0)):
            return "run['cycles_run'] is not a count"
        failed = run.get("failed_cycles")
        if not isinstance(failed, list):
            return "run['failed_cycles'] is not a list"
        for i, c in enumerate(failed):
            if why := _fields(c, f"run['failed_cycles'][{i}]", _FAILED_CYCLE):
                return why
    found = record.get("diagnosis")
    if not isinstance(found, list):
        return "its diagnosis is not a list"
    for i, f in enumerate(found):
        if why := _fields(f, f"diagnosis[{i}]", _FINDING):
            return why
    if why := _fields(record.get("output"), "output", _OUTPUT):
        return why
    if not isinstance(record.get("wall_time_s"), dict):
        return "its wall_time_s is not an object"
    plots = record.get("plots")
    if plots is not None and not (
        isinstance(plots, dict)
        and all(isinstance(k, str) and isinstance(v, str) and v.isascii() for k, v in plots.items())
        and all(v.replace("+", "").replace("/", "").rstrip("=").isalnum() for v in plots.values())
    ):
        return "its plots are not PNG files in base64"
    return ""


# -- text for terminals, JSON and pages ------------------------------------------------------
def printable(text: str, name: bool = False) -> str:
    """``text`` as inert text (:func:`kr210_sim.util.console.escape`): every undecodable byte of
    a file name (a surrogate escape) as ``\\xNN`` and every control character (ESC, BEL, a
    carriage return, a bidi override) as its escape, so no terminal acts on it; a text keeps
    its newlines and tabs, a ``name`` does not (it stays on its line)."""
    return escape(text, lines=not name)


def clean(value: Any) -> Any:
    """``value`` (a JSON-ready tree) with :func:`printable` applied to every string and key."""
    if isinstance(value, str):
        return printable(value)
    if isinstance(value, dict):
        return {printable(str(k)): clean(v) for k, v in value.items()}
    if isinstance(value, list):
        return [clean(v) for v in value]
    return value


def one_line(text: str, limit: int = LINE_LIMIT) -> str:
    """``text`` on one line (whitespace runs as one space), cut to ``limit`` characters."""
    flat = " ".join(text.split())
    return flat if len(flat) <= limit else flat[: limit - 3] + "..."
