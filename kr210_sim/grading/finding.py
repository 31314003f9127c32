"""One named mistake (:class:`Finding`), the record tests the diagnoses share, and the
findings read from the answers' own figures alone: the servers' ``name_error``, ``complex``,
``unevaluated``, ``python2`` and ``compat`` (:func:`server_mistakes`), ``singular_wrist``
(:func:`singular_wrist`), and ``grader_code`` (:func:`grader_code`), from the imports of the
grader's own code that the student's jail refused. :mod:`kr210_sim.grading.diagnose` names them
with the others; its module doc says what each code shows.

Which failed cases a ROS-form server is not failed for (:func:`spared`): those only another
branch reaches inside the limits (:func:`one_branch`) and those at the exact singular wrist
(:func:`exact_singular`), poses the exercise never asked of it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from kr210_sim.exercise.legacy import COMPAT
from kr210_sim.grading.budget import FIRST
from kr210_sim.grading.record import printable
from kr210_sim.sandbox.ik_guard import ORIENTATION_TOL, POSITION_TOL
from kr210_sim.sandbox.user_ik import UserIk

#: |sin q5| below which an answer's wrist counts as straight (singular).
STRAIGHT = 1e-6


@dataclass(frozen=True, slots=True)
class Finding:
    """One named mistake.

    Attributes:
        code: Short name (see the module doc).
        text: What the figures show and what to change, one sentence.
    """

    code: str
    text: str

    def to_dict(self) -> dict[str, str]:
        """The report's record."""
        return {"code": self.code, "text": self.text}


def answered(records: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """The records with an answer."""
    return [r for r in records if r["q"] is not None]


def exact_position(r: dict[str, Any]) -> bool:
    """Whether record ``r``'s answer reaches its pose's position."""
    return r["q"] is not None and r["position_error_m"] <= POSITION_TOL


def wrong_rotation(r: dict[str, Any]) -> bool:
    """Whether record ``r``'s answer misses its pose's orientation."""
    return bool(r["orientation_error_rad"] > ORIENTATION_TOL)


#: The groups whose poses are made from their ``q_ref`` (:mod:`kr210_sim.grading.ikcheck`) and
#: hold one at q5 = 0 exactly: ``q = 0`` and ``q5 = 0``.
STRAIGHT_GROUPS = ("zero", "singular")


def one_branch(r: dict[str, Any]) -> bool:
    """Whether case record ``r`` failed only because its answer, which reaches the pose, lies
    outside the joint limits, on a pose outside the exercise's own groups: what an IK of one
    branch (the exercise's) does where only another branch reaches the pose inside them."""
    return (
        r["group"] not in FIRST  # the exercise's own cases: IK_debug.py's and the cell's
        and not r["passed"]
        and r["q"] is not None
        and r["error"] is None
        and not r["within_limits"]
        and (r["position_error_m"] or 0.0) <= POSITION_TOL
        and (r["orientation_error_rad"] or 0.0) <= ORIENTATION_TOL
    )


def exact_singular(r: dict[str, Any]) -> bool:
    """Whether case record ``r`` failed on a pose at the exact singular wrist (made from a joint
    state with q5 = 0), whatever its answer: there only theta4 + theta6 is defined, the entries
    of R3_6 that give them apart are rounding noise (atan2 of them is any angle, sympy's
    ``atan2(0, 0)`` is nan), and only ``q_ref`` says which split is wanted. The exercise never
    asked a server for such a pose (its IK_debug cases and its cell avoid it)."""
    return not r["passed"] and r["group"] in STRAIGHT_GROUPS and float(r["q_ref"][4]) == 0.0


def spared(r: dict[str, Any], ros: bool) -> bool:
    """Whether failed case ``r`` is said and counted but not failed: for a ROS-form server
    (``ros``), :func:`one_branch` and :func:`exact_singular` cases; for a function of our form
    (given ``q_ref``, which answers both) none."""
    return ros and (one_branch(r) or exact_singular(r))


def singular_wrist(records: Sequence[dict[str, Any]]) -> Finding | None:
    """``singular_wrist``: answers inside the limits with q5 at 0 (or pi) whose position is
    right and orientation is not (see the module doc)."""
    bad = [
        r
        for r in answered(records)
        if r["within_limits"]
        and exact_position(r)
        and wrong_rotation(r)
        and abs(math.sin(r["q"][4])) < STRAIGHT
    ]
    if not bad:
        return None
    worst = max(r["orientation_error_rad"] for r in bad)
    r = bad[0]
    return Finding(
        "singular_wrist",
        f"{len(bad)} answer{'s' if len(bad) != 1 else ''} with the wrist straight (theta5 = 0, "
        f"e.g. case {r['name']}: theta4 = {r['q'][3]:.4f}, theta6 = {r['q'][5]:.4f}) "
        f"{'reach' if len(bad) != 1 else 'reaches'} the position with the orientation off by "
        f"up to {1000 * worst:.1f} mrad: there only "
        "theta4 + theta6 is defined, and the entries of R3_6 that give them apart are rounding "
        "noise; when sin(theta5) is about 0, keep theta4 (0, or the previous answer's) and "
        "take theta6 from the entries that hold theta4 + theta6",
    )


def server_mistakes(records: Sequence[dict[str, Any]], notes: Sequence[str]) -> list[Finding]:
    """``name_error``, ``complex``, ``unevaluated`` and ``python2`` (see the module doc)."""
    found = []
    n = len(records)
    names = [r for r in records if str(r.get("error") or "").startswith(("NameError", "Unbound"))]
    if names:
        found.append(
            Finding(
                "name_error",
                f"{names[0]['error']} on {len(names)} of {n} poses (e.g. {names[0]['name']}): a "
                "name used before it is assigned (a line commented out, a misspelling, or a "
                "name assigned only on another branch)",
            )
        )
    for code, phrase, fix in (
        (
            "complex",
            "a complex number",
            "acos or asin of a value past +-1 (a triangle that cannot close: check the wrist "
            "centre and the side lengths; at full stretch, clip the argument to [-1, 1])",
        ),
        (
            "unevaluated",
            "an unevaluated sympy expression",
            "a symbol left in the expression: substitute every joint angle (subs or "
            "evalf(subs=...)) before the answer is returned",
        ),
    ):
        bad = [r for r in records if phrase in str(r.get("problem") or "")]
        if bad:
            why = str(bad[0]["problem"]).partition("(TypeError: ")[2].rstrip(")")
            what, sep, symbols = why.partition(" has free symbols ")
            what = what.split(":")[0] if not sep else what
            what = what if len(what) <= 80 else what[:77] + "..."
            why = what + (sep + symbols.split(":")[0] if sep else "")
            found.append(
                Finding(
                    code,
                    f"{len(bad)} of {n} answers hold {phrase} (e.g. {bad[0]['name']}: "
                    f"{why}): {fix}",
                )
            )
    compat = [n.removeprefix(COMPAT) for n in notes if n.startswith(COMPAT)]
    py2 = [n for n in notes if not n.startswith(COMPAT)]
    if py2:
        found.append(
            Finding(
                "python2", f"under Python 2, as under ROS, the code computed otherwise: {_few(py2)}"
            )
        )
    if compat:
        found.append(
            Finding(
                "compat",
                "the code relied on what the course's libraries did and today's do not, and "
                f"was run as they did (our environment, not a mistake): {_few(compat)}",
            )
        )
    return found


#: What the grader's own modules are, by name, for :func:`grader_code`'s sentence.
_KINDS = (
    (
        ("kr210_sim.robot.kinematics", "kr210_sim.robot.ik_scalar", "kr210_sim.robot._ik_native"),
        "solver",
    ),
    (("kr210_sim.plan",), "planner"),
    (("kr210_sim.cell", "kr210_sim.scenes", "kr210_sim.assets"), "cells"),
)


def grader_code(blocked: Sequence[str]) -> Finding | None:
    """``grader_code``: the student's code tried to import the grader's own modules (its
    solver, planner, cells), which its jail does not hold; the imports were refused and are
    named here, whatever the student's code then did (None when it tried none)."""
    if not blocked:
        return None
    kinds = [
        kind
        for prefixes, kind in _KINDS
        if any(b == p or b.startswith(p + ".") for b in blocked for p in prefixes)
    ]
    what = ", ".join(kinds[:-1]) + " and " + kinds[-1] if len(kinds) > 1 else (kinds or ["code"])[0]
    names = ", ".join(blocked[:3]) + (f" and {len(blocked) - 3} more" if len(blocked) > 3 else "")
    return Finding(
        "grader_code",
        f"imported the grader's own {what} ({names}): refused, as the jail holds only the "
        "harness; the answers must come from the student's own IK",
    )


def _few(notes: Sequence[str]) -> str:
    return "; ".join(notes[:3]) + (f"; and {len(notes) - 3} more" if len(notes) > 3 else "")


def notes_of(ik: UserIk) -> list[str]:
    """The notes ``ik``'s code sent since they were last taken: its own ``notes`` (in its
    process), or those its sandbox keeps (an :class:`~kr210_sim.sandbox.ik_sandbox.IkSandbox`
    collects them from every answer in its ``notes``); none for an IK of our form."""
    if ik.notes is not None:
        return list(ik.notes())
    kept = getattr(ik.function, "notes", None)
    return [str(n) for n in kept] if isinstance(kept, list) else []


def finding_lines(found: Sequence[Finding | dict[str, str]], indent: str = "  ") -> list[str]:
    """The findings as the commands print them: a heading and one line each (``code: text``,
    made printable: a student's text never reaches a terminal as it is)."""
    if not found:
        return []
    items = [f.to_dict() if isinstance(f, Finding) else f for f in found]
    lines = [f"{indent}diagnosis ({len(items)}):"]
    lines += [
        f"{indent}  {f['code']}: {' '.join(printable(f['text'], name=True).split())}" for f in items
    ]
    return lines
