"""The grade's leaderboard: a table for the terminal, the JSON report and a self-contained page.

Students are sorted by verdict (:data:`~kr210_sim.grading.student.VERDICTS`: pass, fail, timeout,
crashed, error), then by cycles that succeeded, ik-check cases passed, the worst position error
and the name. The page (``--html``) needs no network: its style is inline and its plots are PNG
data URIs; it has no script, and every text on it is escaped. The records given here are
checked ones (:func:`kr210_sim.grading.record.record_problem`).

Every string of a record came from, or quotes, a student. On the terminal each one passes
:func:`~kr210_sim.util.console.escape` (one line: no ESC, BEL or carriage return reaches the
instructor's screen); on the page each one passes :func:`_text` (the same escape, then HTML's).
"""

from __future__ import annotations

import html
import math
from pathlib import Path
from typing import Any

from kr210_sim.grading.record import VERDICTS, printable
from kr210_sim.util.console import escape

#: Captured output shown per student on the page [characters].
PAGE_OUTPUT = 4000
#: Longest name the terminal's table shows whole [characters].
TABLE_NAME = 40
#: Longest diagnosis the page's top table shows whole [characters] (its section has it all).
CELL_TEXT = 160
_COLOURS = {
    "pass": "#1a7f37",
    "fail": "#b35900",
    "timeout": "#8250df",
    "crashed": "#cf222e",
    "error": "#57606a",
}


def _key(r: dict[str, Any]) -> tuple[Any, ...]:
    ik, run = r.get("ik_check") or {}, r.get("run") or {}
    worst = ik.get("max_position_error_m")
    return (
        VERDICTS.index(r["verdict"]) if r["verdict"] in VERDICTS else len(VERDICTS),
        -int(run.get("successes", -1)),
        -int(ik.get("passed", -1)),
        math.inf if worst is None else worst,
        r["name"],
    )


def ranked(records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """``records`` in leaderboard order, without the page-only ``plots``."""
    return [{k: v for k, v in r.items() if k != "plots"} for r in sorted(records, key=_key)]


def build_report(
    records: list[dict[str, Any]],
    config: dict[str, Any],
    workers: int,
    wall_time: float,
    interrupted: BaseException | None,
) -> dict[str, Any]:
    """The JSON-ready report: config, summary (count per verdict), students in order.

    Args:
        records: One per student graded (:func:`kr210_sim.grading.student.grade_student`).
        config: The settings every student was graded with.
        workers: Students graded at once.
        wall_time: Wall-clock time of the grading [s].
        interrupted: The interrupt that stopped it, or None.
    """
    from kr210_sim.util.interrupts import signal_name
    from kr210_sim.util.versions import versions

    counts = {v: 0 for v in VERDICTS}
    for r in records:
        counts[r["verdict"]] = counts.get(r["verdict"], 0) + 1
    return {
        "kind": "kr210_sim.grading",
        "config": config,
        "summary": {
            "students": len(records),
            "verdicts": counts,
            "all_passed": interrupted is None and counts["pass"] == len(records),
        },
        "students": ranked(records),
        "wall_execution": {"workers": workers},
        "interrupted_by": signal_name(interrupted) if interrupted is not None else None,
        "wall_time_s": wall_time,
        "versions": versions(),
    }


def _mm(x: float | None) -> str:
    return "-" if x is None else f"{1000 * x:.3g}"


def _figures(r: dict[str, Any]) -> tuple[str, str, str, str]:
    ik, run = r.get("ik_check"), r.get("run")
    cases = f"{ik['passed']}/{ik['cases']}" if ik else "-"
    pos = _mm(ik["max_position_error_m"]) if ik else "-"
    ori = _mm(ik["max_orientation_error_rad"]) if ik else "-"
    cycles = f"{run['successes']}/{run['cycles']}" if run else "-"
    return cases, pos, ori, cycles


def _short_name(name: str) -> str:
    name = escape(name)
    return name if len(name) <= TABLE_NAME else name[: TABLE_NAME - 3] + "..."


def findings(r: dict[str, Any]) -> list[str]:
    """What the diagnosis of record ``r`` names, one text per finding (as in the record)."""
    return [f["text"] for f in r.get("diagnosis") or []]


def student_line(r: dict[str, Any]) -> str:
    """One line per finished student (printed as each one ends), every text escaped."""
    cases, _, _, cycles = _figures(r)
    return (
        f"{_short_name(r['name']):<20} {escape(r['verdict']):<8} ik-check {cases:<10} "
        f"cycles {cycles:<6} {r['wall_time_s']['total']:6.1f} s  {escape(r['detail'])}"
    )


def table(report: dict[str, Any]) -> str:
    """The leaderboard: a line per student (and for a student who did not pass, every finding
    of its diagnosis, or its detail when there is none), the count per verdict and the overall
    result; every text escaped (:func:`~kr210_sim.util.console.escape`)."""
    rows = [
        f"  {'#':>3}  {'student':<20} {'verdict':<8} {'ik-check':>10} {'worst mm':>9} "
        f"{'worst mrad':>11} {'cycles':>7} {'time s':>7}"
    ]
    for i, r in enumerate(report["students"], start=1):
        cases, pos, ori, cycles = _figures(r)
        name = _short_name(r["name"])
        rows.append(
            f"  {i:>3}  {name:<20} {escape(r['verdict']):<8} {cases:>10} {pos:>9} {ori:>11} "
            f"{cycles:>7} {r['wall_time_s']['total']:>7.1f}"
        )
        if r["verdict"] != "pass":
            rows.extend(f"        {escape(text)}" for text in findings(r) or [r["detail"]])
    s = report["summary"]
    counts = ", ".join(f"{n} {v}" for v, n in s["verdicts"].items() if n)
    rows.append(f"  {s['students']} students: {counts or 'none graded'}")
    if report.get("interrupted_by"):
        rows.append(f"INTERRUPTED ({report['interrupted_by']}): the students above were graded")
    elif s["all_passed"]:
        rows.append(f"PASS: all {s['students']} students passed")
    else:
        rows.append(f"FAIL: {s['students'] - s['verdicts']['pass']} students did not pass")
    return "\n".join(rows)


_STYLE = """
body{font-family:system-ui,sans-serif;margin:2em;max-width:72em;color:#1f2328}
table{border-collapse:collapse}td,th{padding:.25em .7em;border-bottom:1px solid #d0d7de;
text-align:right}td.l,th.l{text-align:left}.v{color:#fff;border-radius:.3em;padding:.1em .5em}
pre{background:#f6f8fa;padding:.6em;overflow-x:auto;max-height:20em}img{max-width:100%}
section{border-top:2px solid #d0d7de;margin-top:2em}code{background:#f6f8fa}
td.d{font-size:.85em;max-width:30em}
"""


def _text(text: str, lines: bool = False) -> str:
    """``text`` for the page: :func:`~kr210_sim.util.console.escape` (no control character;
    ``lines`` keeps newlines and tabs, for a ``<pre>``), then HTML-escaped, quotes included."""
    return html.escape(escape(text, lines=lines), quote=True)


def _badge(verdict: str) -> str:
    colour = _COLOURS.get(verdict, "#57606a")
    return f'<span class="v" style="background:{colour}">{_text(verdict)}</span>'


def answered(r: dict[str, Any]) -> bool:
    """Whether the student of record ``r`` answered any ik-check case with joint angles whose
    error could be measured (the error plots then have something to show)."""
    ik = r.get("ik_check") or {}
    return ik.get("max_position_error_m") is not None


def _diagnosis_cell(r: dict[str, Any]) -> str:
    """The top table's diagnosis: each finding on its line, cut to :data:`CELL_TEXT`
    characters (the detail for a student who did not pass and has none)."""
    texts = findings(r) or ([] if r["verdict"] == "pass" else [r["detail"]])
    cut = [t if len(t) <= CELL_TEXT else t[: CELL_TEXT - 3] + "..." for t in texts]
    return "<br>".join(_text(t) for t in cut)


def _section(i: int, r: dict[str, Any], plots: dict[str, str]) -> str:
    e = _text
    parts = [
        f'<section id="student-{i}"><h2>{e(r["name"])} {_badge(r["verdict"])}</h2>',
        f"<p>{e(r['detail'])}</p>",
    ]
    if r.get("spec"):
        parts.append(f"<p>SPEC <code>{e(r['spec'])}</code></p>")
    if r.get("diagnosis"):
        items = "".join(f"<li>{e(f['text'])}</li>" for f in r["diagnosis"])
        parts.append(f"<h3>What the figures show</h3><ul>{items}</ul>")
    ik = r.get("ik_check")
    if ik:
        parts.append(
            f"<p>ik-check: {ik['passed']}/{ik['cases']} cases; worst position error "
            f"{_mm(ik['max_position_error_m'])} mm, worst orientation error "
            f"{_mm(ik['max_orientation_error_rad'])} mrad; {ik['outside_limits']} outside the "
            f"limits, {ik['raised']} raised, {ik['returned_none']} None; "
            f"{1e6 * ik['wall_time_per_call_s']:.0f} &micro;s per call</p>"
        )
    if answered(r):
        for name, data in sorted(plots.items()):
            parts.append(f'<img alt="{e(name)}" src="data:image/png;base64,{data}">')
    elif ik:
        parts.append("<p>No error plots: it answered none of the cases.</p>")
    run = r.get("run")
    if run:
        ran = run.get("cycles_run", run["cycles"])
        stopped = f" (stopped after {ran})" if ran != run["cycles"] else ""
        parts.append(f"<p>run: {run['successes']}/{run['cycles']} cycles succeeded{stopped}</p>")
        for c in run["failed_cycles"]:
            parts.append(
                f"<p>cycle {c['cycle']} (slot {c['slot']}): <b>{e(c['reason'])}</b> "
                f"{e(c['detail'] or '')}<br>film it: <code>{e(c['replay'])}</code></p>"
            )
    times = r["wall_time_s"]
    own = times.get("student")
    if isinstance(own, int | float):
        parts.append(
            f"<p>time: {own:.2f} s in the student's own code (--timeout), "
            f"{times['total']:.1f} s in all</p>"
        )
    out = r.get("output") or {}
    if out.get("bytes"):
        text = (out.get("stdout", "") + out.get("stderr", ""))[:PAGE_OUTPUT]
        parts.append(
            f"<h3>Output ({out['bytes']} bytes; excerpt)</h3><pre>{e(text, lines=True)}</pre>"
        )
    parts.append("</section>")
    return "\n".join(parts)


def page(report: dict[str, Any], records: list[dict[str, Any]]) -> str:
    """The self-contained HTML page: the leaderboard (with each student's diagnosis) and a
    section per student."""
    e = _text
    plots = {r["name"]: r.get("plots") or {} for r in records}
    rows = []
    for i, r in enumerate(report["students"], start=1):
        cases, pos, ori, cycles = _figures(r)
        rows.append(
            f'<tr><td>{i}</td><td class="l"><a href="#student-{i}">{e(r["name"])}</a></td>'
            f'<td class="l">{_badge(r["verdict"])}</td><td>{cases}</td><td>{pos}</td>'
            f"<td>{ori}</td><td>{cycles}</td><td>{r['wall_time_s']['total']:.1f}</td>"
            f'<td class="l d">{_diagnosis_cell(r)}</td></tr>'
        )
    c = report["config"]
    head = (
        '<tr><th>#</th><th class="l">student</th><th class="l">verdict</th><th>ik-check</th>'
        "<th>worst mm</th><th>worst mrad</th><th>cycles</th><th>time s</th>"
        '<th class="l">diagnosis</th></tr>'
    )
    sections = "\n".join(
        _section(i, r, plots.get(r["name"], {})) for i, r in enumerate(report["students"], start=1)
    )
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        f"<title>kr210_sim grade</title><style>{_STYLE}</style></head><body>\n"
        f"<h1>Leaderboard</h1><p>{report['summary']['students']} students; ik-check with "
        f"{c['cases']} random poses, a run of {c['cycles']} cycles (seed {c['seed']}, pass bar "
        f"{c['min_success']:.0%}), {c['ik_timeout_s']:g} s per IK call, {c['timeout_s']:g} s "
        f"and {c['memory_mb']} MB per student.</p>\n<table>{head}{''.join(rows)}</table>\n"
        f"{sections}\n</body></html>\n"
    )


def write_html(path: Path, report: dict[str, Any], records: list[dict[str, Any]]) -> Path:
    """Write :func:`page` to ``path`` atomically (as UTF-8: a text that is no Unicode, a file
    name's undecodable bytes, is written as ``\\xNN``)."""
    from kr210_sim.util.outputs import write_text_atomic

    return write_text_atomic(path, printable(page(report, records)))
