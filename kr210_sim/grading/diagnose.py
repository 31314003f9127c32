"""Name the classic mistakes of a student's IK from their signatures in the ik-check and the run.

Each finding is a short code and a sentence that says what the figures show and what to change:

* ``offset_0054``: the 0.054 m drop between joints 3 and 4 (DH ``a3``) was left out. Every
  answer then puts gripper_link (and the wrist centre) 54 mm from the pose, with an exact
  orientation.
* ``gripper_frame``: the same rotation separates every answer's orientation from the pose's (a
  fixed frame correction is missing, typically the DH gripper frame against URDF gripper_link,
  ``R_corr = Rz(pi) Ry(-pi/2)``).
* ``wrist_flip``: answers (that reproduce their pose) that are the other wrist solution (joints
  4 and 6 about pi away from the one nearest ``q_ref``), or a cycle that failed on one.
* ``two_pi``: answers 2 pi away from the nearest twin, or a cycle that failed on one.
* ``outside_limits``: answers outside the joint limits (with no 2 pi twin inside them).
* ``unusable``: answers that are not six finite joint angles: NaN or inf (a math domain error),
  not numbers at all (a generator, a dict), or the wrong shape; one finding per kind.
* ``raised`` / ``none``: the function raised, or returned None for poses that can be reached.

The mistakes of the original exercise's servers (:mod:`kr210_sim.exercise`):

* ``stale_rotation``: answers with an earlier pose's orientation: a rotation matrix
  overwritten with one pose's numbers (``R = R.subs(...)`` in the loop) and reused for the next.
* ``wrist_angles``: the wrist centre right, the orientation not: theta1-3 are right, theta4-6
  are not (``R0_3`` evaluated at other angles, or theta4-6 read from the wrong entries of
  ``R3_6``, or the other wrist solution's theta4 and theta6 with this one's theta5).
* ``gripper_length``: the orientation right and the position off by the same distance along
  the gripper's axis: the wrist centre found with another gripper length than 0.303 m.
* ``theta3_offset``: the orientation right and the wrist centre off by the same distance on
  every answer: theta3 is off by a constant angle (the correction for the 0.054 m drop with
  the wrong sign is 0.072 rad).
* ``singular_wrist``: answers with the wrist straight (q5 = 0) that reach the position with
  the orientation wrong: q4 and q6 taken apart from entries that are rounding noise there,
  where only their sum is defined.
* ``euler_order``: positions exact, orientations off by a rotation that changes from pose to
  pose: the rotation built from roll, pitch and yaw is not the pose's (the order named when one
  of the six orders of the elementary rotations explains the answers).
* ``name_error``: a ``NameError`` (or ``UnboundLocalError``) on the poses, with its line.
* ``complex`` / ``unevaluated``: answers holding complex numbers (``acos`` of a value past 1) or
  sympy expressions with free symbols.
* ``python2``: where Python 2 semantics changed what the code computed, as they did under ROS
  (``1/2 == 0``, a list comprehension's variable overwriting another value), from the notes the
  server's process sent (:class:`~kr210_sim.exercise.py2.Notes`).
* ``compat``: what the course's libraries did and today's do not, which the server needed and
  was given (:mod:`kr210_sim.exercise.legacy`: a ragged array, ``numpy.float``): our
  environment, not the student's mistake.
* ``same_offset``, ``failed_cases`` and ``failed_cycles`` (:mod:`kr210_sim.grading.misses`):
  every answer off by one vector; and, last, the failed cases and cycles nothing above explains,
  each named with what it missed.

The figures come from :mod:`kr210_sim.grading.ikcheck` records (and, for ``gripper_frame``, the
cases' poses, whose rotations the records do not keep).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from kr210_sim.grading.finding import STRAIGHT, Finding, server_mistakes, singular_wrist
from kr210_sim.grading.finding import answered as _answered
from kr210_sim.grading.finding import exact_position as _exact_position
from kr210_sim.grading.finding import wrong_rotation as _wrong_rotation
from kr210_sim.grading.misses import failed_cases, same_offset
from kr210_sim.grading.misses import failed_cycles as _unnamed_cycles
from kr210_sim.robot.kinematics import Kinematics
from kr210_sim.sandbox.ik_guard import ORIENTATION_TOL, POSITION_TOL

FloatArray = npt.NDArray[np.float64]

#: The DH offset a3 students leave out [m].
A3_OFFSET = 0.054
#: How close to :data:`A3_OFFSET` an answer's position error must be to count [m].
A3_BAND = 0.003
#: Share of the answers that must show a signature for the whole function to be named by it.
MAJORITY = 0.8
#: Smallest fixed rotation named (below the check's 1 mrad it would pass) [rad].
MIN_FIXED_ROTATION = 1e-3
#: How much the rotation error may vary between answers and still be "the same" [rad].
SAME_ROTATION = 0.01


def _rotation_of(R: FloatArray) -> tuple[float, FloatArray]:
    """Angle [rad] and unit axis of rotation matrix ``R``."""
    angle = math.acos(max(-1.0, min(1.0, (float(np.trace(R)) - 1.0) / 2.0)))
    axis = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    n = float(np.linalg.norm(axis))
    if n < 1e-9:  # angle 0 or pi: the axis is the column of R + I with the largest norm
        M = R + np.eye(3)
        axis = M[:, int(np.argmax(np.linalg.norm(M, axis=0)))]
        n = float(np.linalg.norm(axis)) or 1.0
    return angle, axis / n


def offset_left_out(records: Sequence[dict[str, Any]]) -> Finding | None:
    """``offset_0054`` when most answers miss by 54 mm (see the module doc)."""
    answered = _answered(records)
    if not answered:
        return None
    near = [r for r in answered if abs(r["position_error_m"] - A3_OFFSET) <= A3_BAND]
    if len(near) < MAJORITY * len(answered):
        return None
    median = float(np.median([r["position_error_m"] for r in near]))
    return Finding(
        "offset_0054",
        f"{len(near)} of {len(answered)} answers put gripper_link {1000 * median:.1f} mm from "
        "the pose: the 0.054 m drop between joints 3 and 4 (a3 = -0.054 in the DH table) was "
        "left out of the wrist-centre triangle",
    )


def fixed_rotation(
    kin: Kinematics, records: Sequence[dict[str, Any]], poses: Sequence[FloatArray]
) -> Finding | None:
    """``gripper_frame`` when every answer's orientation is off by the same rotation.

    Args:
        kin: The kinematics of the robot the answers are for.
        records: ik-check records.
        poses: The requested pose (4x4) of each record, in the same order.
    """
    rel = []
    for r, T in zip(records, poses, strict=True):
        if r["q"] is None:
            continue
        Rq = kin.forward(np.asarray(r["q"], dtype=np.float64))[:3, :3]
        rel.append(T[:3, :3].T @ Rq)  # the error, in the requested gripper frame
    if len(rel) < 3:
        return None
    mean_angle = float(np.median([_rotation_of(R)[0] for R in rel]))
    if mean_angle < MIN_FIXED_ROTATION:
        return None
    first = rel[0]
    spread = max(_rotation_of(first.T @ R)[0] for R in rel)
    if spread > SAME_ROTATION:
        return None
    angle, axis = _rotation_of(first)
    about = (np.round(axis, 2) + 0.0).tolist()  # + 0.0: no "-0.0"
    return Finding(
        "gripper_frame",
        f"every answer's orientation is off by the same rotation, {math.degrees(angle):.1f} "
        f"deg about {about} of gripper_link: a fixed frame correction is "
        "missing, e.g. the DH gripper frame against URDF gripper_link "
        "(R_corr = Rz(pi) Ry(-pi/2))",
    )


def _branch_counts(records: Sequence[dict[str, Any]]) -> dict[str, int]:
    """Branch changes among the answers that reproduce their pose (a wrong answer is no
    branch)."""
    counts: dict[str, int] = {}
    for r in records:
        kind = r.get("branch_change")
        exact = r["q"] is not None and (
            r["position_error_m"] <= POSITION_TOL and r["orientation_error_rad"] <= ORIENTATION_TOL
        )
        if kind and exact:
            counts[kind] = counts.get(kind, 0) + 1
    return counts


#: The kinds of unusable answer: a phrase of the check's ``problem``, what it is, what to do.
_UNUSABLE = (
    (
        "NaN or inf",
        "are NaN or inf",
        "a math domain error is likely (acos or asin of a value past +-1, the square root of a "
        "negative number, a division by zero): clamp the argument, and return None for a pose "
        "that cannot be reached",
    ),
    (
        "not six numbers",
        "are not numbers",
        "return a list, tuple or array of six floats [rad] (or None)",
    ),
    (
        "not six angles",
        "do not hold six angles",
        "return the six joint angles [rad] of one solution, joint_1 first (or None)",
    ),
)


#: Unusable answers a finding of their own names (``complex``, ``unevaluated``).
_NAMED_ELSEWHERE = ("a complex number", "an unevaluated sympy expression")


def unusable_answers(records: Sequence[dict[str, Any]]) -> list[Finding]:
    """``unusable``: answers that are no six finite angles, one finding per kind (see the
    module doc), the most frequent first."""
    found = []
    for phrase, what, fix in _UNUSABLE:
        bad = [
            r
            for r in records
            if r["q"] is None
            and not r.get("error")
            and phrase in str(r.get("problem") or "")
            and not any(k in str(r.get("problem")) for k in _NAMED_ELSEWHERE)
        ]
        if bad:
            text = (
                f"{len(bad)} of {len(records)} answers {what} (e.g. {bad[0]['name']}: "
                f"{bad[0]['problem']}): {fix}"
            )
            found.append((len(bad), Finding("unusable", text)))
    found.sort(key=lambda nf: -nf[0])
    return [f for _, f in found]


def _rpy(R: FloatArray) -> tuple[float, float, float]:
    """Roll, pitch and yaw of ``R`` as tf's ``euler_from_matrix`` gives them (static x, y, z:
    ``R = Rz(yaw) Ry(pitch) Rx(roll)``)."""
    cy = math.hypot(R[0, 0], R[1, 0])
    if cy > 1e-12:
        return math.atan2(R[2, 1], R[2, 2]), math.atan2(-R[2, 0], cy), math.atan2(R[1, 0], R[0, 0])
    return math.atan2(-R[1, 2], R[1, 1]), math.atan2(-R[2, 0], cy), 0.0


def _elementary(axis: str, a: float) -> FloatArray:
    c, s = math.cos(a), math.sin(a)
    if axis == "x":
        return np.array([[1.0, 0, 0], [0, c, -s], [0, s, c]])
    if axis == "y":
        return np.array([[c, 0, s], [0, 1.0, 0], [-s, 0, c]])
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


#: The six orders of the elementary rotations, as a student writes them (left to right).
_ORDERS = ("zyx", "xyz", "xzy", "yxz", "yzx", "zxy")
_NAMES = {"x": "Rx(roll)", "y": "Ry(pitch)", "z": "Rz(yaw)"}
#: How close an answer's rotation must be to another to count as it [Frobenius norm].
_SAME = 1e-6
#: Fewest answers a rotation mistake is named from.
FEW = 3


def _wrong_orientation(records: Sequence[dict[str, Any]]) -> list[int]:
    """Indices of the answers with their position right and their orientation wrong."""
    return [
        i
        for i, r in enumerate(records)
        if _exact_position(r) and r["orientation_error_rad"] > ORIENTATION_TOL
    ]


def stale_rotation(
    kin: Kinematics, records: Sequence[dict[str, Any]], poses: Sequence[FloatArray]
) -> Finding | None:
    """``stale_rotation``: most answers with their orientation wrong (at least :data:`FEW`;
    their position right or not: a wrist centre found from the stale rotation misses too) have
    an earlier pose's orientation."""
    answered = [r for r in records if r["q"] is not None]
    wrong = [i for i, r in enumerate(records) if r["q"] is not None and _wrong_rotation(r)]
    if len(wrong) < FEW:
        return None
    rotations = np.array([np.asarray(T)[:3, :3] for T in poses])
    stale = []
    for i in wrong:
        R = kin.forward(np.asarray(records[i]["q"], dtype=np.float64))[:3, :3]
        gaps = np.linalg.norm((rotations[:i] - R).reshape(i, 9), axis=1)
        if i and float(gaps.min()) < _SAME:
            stale.append((i, int(np.argmin(gaps))))
    if len(stale) < MAJORITY * len(wrong):
        return None
    i, j = stale[0]
    exact = sum(_exact_position(records[k]) for k, _ in stale)
    reach = "reach their pose's position with" if exact == len(stale) else "have"
    return Finding(
        "stale_rotation",
        f"{len(stale)} of {len(answered)} answers {reach} the "
        f"orientation of an earlier pose (e.g. {records[i]['name']} has {records[j]['name']}'s): "
        "a rotation matrix is overwritten with one pose's numbers and reused for the next "
        "(R = R.subs(...) inside the loop over the poses); substitute into a new name for each "
        "pose",
    )


#: Distance from joint 3 to the wrist centre, sqrt(1.5^2 + 0.054^2) [m]: a constant theta3
#: error moves the wrist centre by 2 L sin(error / 2), the same on every answer.
L3 = math.hypot(1.5, A3_OFFSET)
#: The drop's angle, atan2(0.054, 1.5) [rad]: theta3 off by twice it is the correction's sign.
SAG = math.atan2(A3_OFFSET, 1.5)
#: How close two wrist-centre errors must be to be "the same" [m].
SAME_DISTANCE = 1e-3


def wrist_angles(records: Sequence[dict[str, Any]]) -> Finding | None:
    """``wrist_angles``: on most of the answers that miss (at least :data:`FEW`) the wrist
    centre is right and the orientation is not (see the module doc)."""
    answered = _answered(records)
    inside = [  # those outside the limits, and with the wrist straight, are named as such
        r for r in answered if r["within_limits"] and abs(math.sin(r["q"][4])) >= STRAIGHT
    ]
    failing = [r for r in inside if _wrong_rotation(r) or r["position_error_m"] > POSITION_TOL]
    bad = [r for r in failing if r["wrist_centre_error_m"] <= POSITION_TOL and _wrong_rotation(r)]
    if len(bad) < FEW or len(bad) < MAJORITY * len(failing):
        return None
    worst = max(r["orientation_error_rad"] for r in bad)
    return Finding(
        "wrist_angles",
        f"{len(bad)} of {len(answered)} answers put the wrist centre where it belongs (within "
        f"{1000 * POSITION_TOL:g} mm) with the orientation off by up to "
        f"{math.degrees(worst):.0f} deg: theta1-3 are right and theta4-6 are not (check that "
        "R0_3 is evaluated at theta1, theta2 and theta3, that R3_6 = R0_3.T * Rrpy with the "
        "gripper correction, and which entries of R3_6 theta4, theta5 and theta6 read; the "
        'other wrist solution flips the signs of all three; R0_3.inv("LU") is not R0_3\'s '
        "inverse for most poses, its leading 2x2 block being singular: sympy's LU pivots on "
        "round-off there, as it did in 2017)",
    )


def gripper_length(
    kin: Kinematics, records: Sequence[dict[str, Any]], poses: Sequence[FloatArray]
) -> Finding | None:
    """``gripper_length``: the answers with their orientation right and their position wrong
    (at least :data:`FEW`) mostly miss it by the same distance along the gripper's axis: the
    wrist centre was found with another gripper length (see the module doc)."""
    dg = kin.geometry.dg
    along = []
    off = 0
    for r, T in zip(records, poses, strict=True):
        if r["q"] is None or _wrong_rotation(r) or r["position_error_m"] <= POSITION_TOL:
            continue
        off += 1
        e = kin.forward(np.asarray(r["q"], dtype=np.float64))[:3, 3] - T[:3, 3]
        x = T[:3, 0]  # gripper_link's axis: the wrist centre is dg behind it along x
        a = float(e @ x)
        if float(np.linalg.norm(e - a * x)) <= POSITION_TOL:
            along.append(a)
    if off < FEW or len(along) < MAJORITY * off:
        return None
    a = float(np.median(along))
    if sum(abs(v - a) <= SAME_DISTANCE for v in along) < MAJORITY * off:
        return None
    used = dg - a
    where = "short of" if a < 0 else "past"
    return Finding(
        "gripper_length",
        f"{len(along)} answers with the orientation right stop {1000 * abs(a):.0f} mm {where} "
        f"their pose along the gripper's axis, the same on each: the wrist centre was found "
        f"{used:.3f} m behind gripper_link, where it is {dg:.3f} m (d7 = 0.193 + 0.11 in the DH "
        "table: joint 6 to the gripper's origin)",
    )


def theta3_offset(records: Sequence[dict[str, Any]]) -> Finding | None:
    """``theta3_offset``: the answers with their orientation right and their wrist centre
    wrong (at least :data:`FEW`) mostly miss it by the same distance (see the module doc)."""
    off = [
        r
        for r in _answered(records)
        if not _wrong_rotation(r) and r["wrist_centre_error_m"] > POSITION_TOL
    ]
    if len(off) < FEW:
        return None
    d = float(np.median([r["wrist_centre_error_m"] for r in off]))
    same = [r for r in off if abs(r["wrist_centre_error_m"] - d) <= SAME_DISTANCE]
    if len(same) < MAJORITY * len(off) or abs(d - A3_OFFSET) <= A3_BAND:
        return None  # varying, or the drop left out (offset_0054 names it)
    error = 2.0 * math.asin(min(1.0, d / (2.0 * L3)))
    text = (
        f"{len(same)} answers with the orientation right put the wrist centre "
        f"{1000 * d:.0f} mm from where it belongs, the same on each: theta3 is off by a constant "
        f"{error:.3f} rad ({math.degrees(error):.1f} deg)"
    )
    if abs(error - 2 * SAG) <= 0.003:
        text += (
            f", twice the drop's {SAG:.3f} rad: its correction has the wrong sign (theta3 = "
            "pi/2 - (angle + 0.036); with a3 = -0.054, atan2(a3, d4) is -0.036)"
        )
    else:
        text += " (check the constant terms of theta3: pi/2 and the drop's 0.036 rad)"
    return Finding("theta3_offset", text)


def euler_order(
    kin: Kinematics, records: Sequence[dict[str, Any]], poses: Sequence[FloatArray]
) -> Finding | None:
    """``euler_order``: positions exact, orientations off by a varying rotation, on most answers
    or on at least :data:`FEW` that one order of the elementary rotations explains (it is named;
    the poses it gets right are those where the order makes no difference)."""
    wrong = _wrong_orientation(records)
    answered = [r for r in records if r["q"] is not None]
    if len(wrong) < FEW:
        return None
    worst = max(records[i]["orientation_error_rad"] for i in wrong)
    votes = dict.fromkeys(_ORDERS[1:], 0)
    for i in wrong:
        R = kin.forward(np.asarray(records[i]["q"], dtype=np.float64))[:3, :3]
        angles = dict(zip("xyz", _rpy(np.asarray(poses[i])[:3, :3]), strict=True))
        for order in votes:
            M = np.eye(3)
            for axis in order:
                M = M @ _elementary(axis, angles[axis])
            if float(np.linalg.norm(M - R)) < _SAME:
                votes[order] += 1
    order, n = max(votes.items(), key=lambda kv: kv[1])
    text = (
        f"positions exact, orientations off by up to {math.degrees(worst):.0f} deg on "
        f"{len(wrong)} of {len(answered)} answers: the rotation built from roll, pitch and yaw "
        "is not the pose's"
    )
    named = n >= MAJORITY * len(wrong)
    if not named and len(wrong) < MAJORITY * len(answered):
        return None
    if named:
        yours = " ".join(_NAMES[a] for a in order)
        text += (
            f" (yours is {yours}; tf's euler_from_quaternion gives the angles about the fixed "
            "x, y and z axes, so R = Rz(yaw) Ry(pitch) Rx(roll))"
        )
    else:
        text += " (check the order of the elementary rotations: R = Rz(yaw) Ry(pitch) Rx(roll))"
    return Finding("euler_order", text)


def _cycles_with(failed: Sequence[dict[str, Any]], words: str) -> list[int]:
    return [int(c["cycle"]) for c in failed if words in str(c.get("detail") or "")]


def diagnose(
    kin: Kinematics,
    records: Sequence[dict[str, Any]],
    poses: Sequence[FloatArray],
    failed_cycles: Sequence[dict[str, Any]] = (),
    notes: Sequence[str] = (),
    no_q_ref: bool = False,
) -> list[Finding]:
    """The classic mistakes visible in an ik-check and a run.

    Args:
        kin: The kinematics of the robot the answers are for.
        records: ik-check records (:func:`kr210_sim.grading.ikcheck.case_record`).
        poses: The requested pose of each record (4x4).
        failed_cycles: The run's failed cycles, each with ``cycle`` and ``detail``.
        notes: What Python 2 semantics changed in an original-form server's code (its
            sandbox's notes).
        no_q_ref: The IK was never sent ``q_ref`` (an original-form server: a request holds
            poses only), so what to do is said without it, and the cases it is not failed for
            (:func:`~kr210_sim.grading.finding.spared`) are not named as failures.

    Returns:
        The findings, most telling first (empty when nothing is recognised).
    """
    found: list[Finding] = []
    for f in (offset_left_out(records), fixed_rotation(kin, records, poses)):
        if f is not None:
            found.append(f)
    if not found:  # a varying rotation: an earlier pose's, or the Euler angles composed wrong
        f = (
            stale_rotation(kin, records, poses)
            or euler_order(kin, records, poses)
            or wrist_angles(records)
        )
        found += [f] if f is not None else []
        if not any(f.code == "wrist_angles" for f in found):
            f = (
                gripper_length(kin, records, poses)
                or same_offset(kin, records, poses)
                or theta3_offset(records)
            )
            found += [f] if f is not None else []
    if not any(f.code in ("stale_rotation", "euler_order") for f in found):
        f = singular_wrist(records)
        found += [f] if f is not None else []
    found.extend(server_mistakes(records, notes))
    found.extend(unusable_answers(records))
    # answers outside the limits fail their cases; branch changes are flagged, not failed
    outside = [r for r in records if r["q"] is not None and not r["within_limits"]]
    if outside:
        r = outside[0]
        found.append(
            Finding(
                "outside_limits",
                f"{len(outside)} answers lie outside the joint limits, for poses the arm reaches "
                f"inside them (e.g. case {r['name']} at {r['position']}: {r['problem']}): an IK "
                "of one branch (theta1 = atan2(wy, wx), one elbow, one wrist) misses the poses "
                "only another reaches inside the limits; try the others (theta1 + pi with the "
                "arm over its back, the other elbow, the other wrist) and keep one inside them",
            )
        )
    counts = _branch_counts(records)
    wrist_fix = "of the wrist's two solutions return the one nearest q_ref"
    if no_q_ref:  # a request carries no joint state: the previous pose's answer is all it has
        wrist_fix = (
            "of the wrist's two solutions keep the one nearest the previous pose's answer (a "
            "request holds no joint state; ik-check flags these and does not fail them)"
        )
    for code, kind, fix in (
        ("wrist_flip", "wrist flip", wrist_fix),
        ("two_pi", "2pi jump", "return the 2 pi twin of each angle nearest q_ref"),
    ):
        cycles = _cycles_with(failed_cycles, kind)
        if counts.get(kind) or cycles:
            parts = []
            if counts.get(kind):
                ref = "the solution nearest the arm's joints" if no_q_ref else "q_ref"
                parts.append(f"{counts[kind]} ik-check answers are a {kind} from {ref}")
            if cycles:
                which = ", ".join(str(c) for c in cycles)
                parts.append(f"cycle{'s' if len(cycles) > 1 else ''} {which} failed on a {kind}")
                parts[-1] += " on a straight-line move"
            found.append(Finding(code, f"{'; '.join(parts)}: {fix}"))
    raised = [r for r in records if r.get("error")]
    if raised:
        found.append(
            Finding(
                "raised",
                f"the function raised on {len(raised)} poses (e.g. {raised[0]['name']}: "
                f"{raised[0]['error']})",
            )
        )
    nones = [r for r in records if r.get("returned_none")]
    if nones:
        found.append(
            Finding(
                "none",
                f"the function returned None for {len(nones)} reachable poses (e.g. "
                f"{nones[0]['name']})",
            )
        )
    last = (failed_cases(records, found, ros=no_q_ref), _unnamed_cycles(failed_cycles))
    return found + [f for f in last if f is not None]  # every failed case and cycle named
