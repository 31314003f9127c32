"""One named mistake (:class:`Finding`), the record tests the diagnoses share, and the
findings read from the answers' own figures alone: the servers' ``name_error``, ``complex``,
``unevaluated`` and ``python2`` (:func:`server_mistakes`) and ``singular_wrist``
(:func:`singular_wrist`); and ``grader_code`` (:func:`grader_code`), from the imports of the
grader's own code that the student's jail refused. :mod:`kr210_sim.grading.diagnose` names them
with the others; its module doc says what each code shows.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from kr210_sim.sandbox.ik_guard import ORIENTATION_TOL, POSITION_TOL

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
    if notes:
        shown = "; ".join(notes[:3]) + (f"; and {len(notes) - 3} more" if len(notes) > 3 else "")
        found.append(
            Finding(
                "python2", f"under Python 2, as under ROS, the code computed otherwise: {shown}"
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
