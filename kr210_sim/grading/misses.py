"""What the failed cases missed, when no pattern of :mod:`kr210_sim.grading.diagnose` explains
them: ``same_offset`` (every answer off by one vector), ``failed_cases`` (the cases named,
with the tolerance each missed, in the student's terms) and ``failed_cycles`` (the run's failed
cycles no finding names), so that no ``fail`` goes without its cause.

* ``same_offset``: the answers that miss their position (at least
  :data:`~kr210_sim.grading.diagnose.FEW`) mostly miss it by the same vector, in base_link or in
  gripper_link's frame: a frame or a point is misplaced by a constant (not a formula wrong).
* ``failed_cases``: the failed cases no other finding explains (a ROS-form server's spared ones,
  :func:`~kr210_sim.grading.finding.spared`, are not failed), the worst named with how far each
  is from its pose against what is allowed; a *near miss* (every one within
  :data:`NEAR` times the tolerance) is said to be a question of precision, not of the formula.
* ``failed_cycles``: the run's failed cycles that no branch finding (``wrist_flip``,
  ``two_pi``) names, each with its reason and the run's own words for it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from kr210_sim.grading.finding import STRAIGHT, Finding, spared
from kr210_sim.robot.kinematics import Kinematics
from kr210_sim.sandbox.ik_guard import ORIENTATION_TOL, POSITION_TOL

FloatArray = npt.NDArray[np.float64]

#: Findings that explain answers that miss their pose (their position or orientation).
PATTERNS = frozenset(
    {
        "offset_0054",
        "gripper_frame",
        "stale_rotation",
        "euler_order",
        "wrist_angles",
        "gripper_length",
        "theta3_offset",
        "same_offset",
    }
)
#: A miss within this many times the tolerance is a near miss (a question of precision).
NEAR = 10.0
#: Failed cases named by ``failed_cases``.
SHOWN = 3
#: |theta5| below which a near miss is said to be near the wrist singularity [rad].
NEAR_SINGULAR = 0.05
#: How close two offsets must be to be "the same" [m].
SAME_OFFSET = 1e-3
#: Fewest answers a constant offset is named from, and the share of the misses it must hold.
FEW = 3
MAJORITY = 0.8


def same_offset(
    kin: Kinematics, records: Sequence[dict[str, Any]], poses: Sequence[FloatArray]
) -> Finding | None:
    """``same_offset`` (see the module doc); the frame it is constant in is named."""
    base, tool = [], []
    for r, T in zip(records, poses, strict=True):
        if r["q"] is None or r["position_error_m"] is None or r["position_error_m"] <= POSITION_TOL:
            continue
        e = kin.forward(np.asarray(r["q"], dtype=np.float64))[:3, 3] - np.asarray(T)[:3, 3]
        base.append(e)
        tool.append(np.asarray(T)[:3, :3].T @ e)
    if len(base) < FEW:
        return None
    for errors, frame, why in (
        (
            base,
            "base_link",
            "the same vector whatever the pose and the arm's joints: a frame of yours is "
            "shifted (the pose is gripper_link's origin in base_link; check where your chain "
            "starts, d1 = 0.75 m from base_link to joint 2's height with a1 = 0.35 m, and any "
            "offset you add to px, py, pz or to the wrist centre)",
        ),
        (
            tool,
            "gripper_link's frame",
            "the point your IK solves for is not gripper_link's origin but one fixed beside it "
            "(a tool point, the fingertips, or the wrist centre taken along another axis than "
            "gripper_link's x)",
        ),
    ):
        arr = np.array(errors)
        median = np.median(arr, axis=0)
        near = np.linalg.norm(arr - median, axis=1) <= SAME_OFFSET
        if int(near.sum()) >= MAJORITY * len(arr):
            size = 1000 * float(np.linalg.norm(median))
            vector = (np.round(1000 * median, 1) + 0.0).tolist()
            return Finding(
                "same_offset",
                f"{int(near.sum())} of {len(arr)} answers that miss their position miss it by "
                f"the same {size:.0f} mm, {vector} mm in {frame}: {why}",
            )
    return None


def _badness(r: dict[str, Any]) -> float:
    if r["q"] is None:
        return math.inf
    return max(
        (r["position_error_m"] or 0.0) / POSITION_TOL,
        (r["orientation_error_rad"] or 0.0) / ORIENTATION_TOL,
    ) + (0.0 if r["within_limits"] else 1.0)


def _explained(r: dict[str, Any], codes: set[str]) -> bool:
    """Whether another finding accounts for failed case ``r``."""
    if r["q"] is None or not r["within_limits"]:  # raised, None, unusable, outside_limits
        return True
    if "singular_wrist" in codes and abs(math.sin(r["q"][4])) < STRAIGHT:
        return True
    return bool(codes & PATTERNS)


def _miss(r: dict[str, Any]) -> str:
    """How far the answer of case ``r`` is from its pose, against what is allowed."""
    parts = []
    for value, tol, unit, what in (
        (r["position_error_m"], POSITION_TOL, "mm", "position"),
        (r["orientation_error_rad"], ORIENTATION_TOL, "mrad", "orientation"),
    ):
        side = "past" if value > tol else "within"
        parts.append(
            f"{1000 * value:.3g} {unit} from its {what} ({side} the {1000 * tol:g} {unit} allowed)"
        )
    return " and ".join(parts)


def _spread(values: list[float], unit: str) -> str:
    lo, mid, hi = min(values), float(np.median(values)), max(values)
    if hi - lo <= 0.02 * max(hi, 1e-12):
        return f"{1000 * mid:.3g} {unit}"
    return f"{1000 * mid:.3g} {unit} (median; {1000 * lo:.3g} to {1000 * hi:.3g})"


def failed_cases(
    records: Sequence[dict[str, Any]], found: Sequence[Finding], ros: bool = False
) -> Finding | None:
    """``failed_cases`` (see the module doc), or None when every failed case is explained.

    Args:
        records: ik-check records.
        found: The findings made so far (which explain some cases).
        ros: A ROS-form server: its spared cases are not failures.
    """
    codes = {f.code for f in found}
    failing = [r for r in records if not r["passed"] and not spared(r, ros)]
    missed = sorted((r for r in failing if not _explained(r, codes)), key=_badness, reverse=True)
    if not missed:
        return None
    n, total = len(missed), len(records)
    named = "; ".join(f"{r['name']} at {r['position']}: {_miss(r)}" for r in missed[:SHOWN])
    more = f"; and {n - SHOWN} more" if n > SHOWN else ""
    head = f"{n} of {total} cases fail{' (every one)' if n == total else ''}: {named}{more}"
    if _badness(missed[0]) <= NEAR:
        text = (
            f"{head}. A question of precision, not of the formula: "
            f"{'each answer misses' if n > 1 else 'the answer misses'} by less than {NEAR:g} "
            "times what is allowed (1 mrad moves the fingertips 0.2 mm); look for a constant "
            "rounded (pi as 3.1416, a DH length to 2 digits), an evalf with few digits, or an "
            "angle from acos or asin of a value near +-1 (atan2 of two entries keeps the digits)"
        )
        q5 = min(abs(r["q"][4]) for r in missed[:SHOWN])
        if q5 < NEAR_SINGULAR:
            text += (
                f"; near the wrist singularity (theta5 = {q5:.2g} rad) theta4 and theta6 come "
                "from small entries of R3_6, where rounding weighs most, and a threshold that "
                "treats the wrist as straight too early misses by about theta5"
            )
        return Finding("failed_cases", text)
    pos = [r["position_error_m"] for r in missed]
    ori = [r["orientation_error_rad"] for r in missed]
    text = (
        f"{head}. They miss their position by {_spread(pos, 'mm')} and their orientation by "
        f"{_spread(ori, 'mrad')}: "
    )
    if max(ori) <= ORIENTATION_TOL:
        text += (
            "the orientation right, the position not: a length or an offset of the arm is off "
            "(compare your DH table with the URDF's: d1 = 0.75, a1 = 0.35, a2 = 1.25, "
            "a3 = -0.054, d4 = 1.5, d7 = 0.303 m)"
        )
    elif max(pos) <= POSITION_TOL:
        text += (
            "the position right, the orientation not: check the rotation built from roll, "
            "pitch and yaw, the correction R_corr between the DH and the URDF gripper frames, "
            "and the entries of R3_6 that theta4, theta5 and theta6 are read from"
        )
    else:
        text += (
            "both wrong: compute forward kinematics of your answer and compare it with the "
            "pose, joint by joint against the DH table (d1 = 0.75, a1 = 0.35, a2 = 1.25, "
            "a3 = -0.054, d4 = 1.5, d7 = 0.303 m)"
        )
    return Finding("failed_cases", text)


#: Words of a failed cycle's detail that a finding of its own names (``wrist_flip``,
#: ``two_pi``).
NAMED_CYCLES = ("wrist flip", "2pi jump")
#: Characters of a failed cycle's detail quoted.
DETAIL = 240


def failed_cycles(failed: Sequence[dict[str, Any]]) -> Finding | None:
    """``failed_cycles`` (see the module doc), or None when no cycle failed unnamed.

    Args:
        failed: The run's failed cycles, each with ``cycle`` and ``detail`` (and, when known,
            ``slot`` and ``reason``).
    """
    others = [c for c in failed if not any(w in str(c.get("detail") or "") for w in NAMED_CYCLES)]
    if not others:
        return None

    def one(c: dict[str, Any]) -> str:
        slot = f" (slot {c['slot']})" if c.get("slot") else ""
        detail = " ".join(str(c.get("detail") or "").split())
        detail = detail if len(detail) <= DETAIL else detail[: DETAIL - 3] + "..."
        why = ": ".join(str(v) for v in (c.get("reason"), detail) if v)
        return f"cycle {c['cycle']}{slot}: {why or 'failed'}"

    n = len(others)
    shown = "; ".join(one(c) for c in others[:SHOWN])
    more = f"; and {n - SHOWN} more" if n > SHOWN else ""
    return Finding(
        "failed_cycles",
        f"{n} cycle{'s' if n != 1 else ''} of the run failed: {shown}{more} (each cycle's "
        "replay command films it)",
    )
