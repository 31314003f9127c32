"""The classic IK mistakes named from their signatures (grading/diagnose.py)."""

from __future__ import annotations

import io
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from kr210_sim.errors import UnreachablePoseError
from kr210_sim.grading.diagnose import diagnose
from kr210_sim.grading.ikcheck import Case, check, fixed_cases, random_cases
from kr210_sim.robot import kinematics
from kr210_sim.sandbox.user_ik import UserIk

KIN = kinematics.committed()


@pytest.fixture(scope="module")
def cases() -> list[Case]:
    return fixed_cases(KIN) + random_cases(KIN, 60, seed=4)


def _codes(cases: list[Case], fn: Callable[..., Any], failed: tuple[Any, ...] = ()) -> list[str]:
    records = check(KIN, UserIk("test:solve", fn), cases, io.StringIO())
    return [f.code for f in diagnose(KIN, records, [c.T for c in cases], failed)]


def _rz(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    out = np.eye(4)
    out[:2, :2] = [[c, -s], [s, c]]
    return out


def test_a_correct_ik_shows_nothing(cases: list[Case]) -> None:
    assert _codes(cases, kinematics.nearest) == []


def test_the_missing_offset_is_named_with_its_54_mm(cases: list[Case], no_offset_ik: str) -> None:
    from kr210_sim.sandbox.user_ik import load_ik

    fn = load_ik(no_offset_ik).function
    records = check(KIN, UserIk(no_offset_ik, fn), cases, io.StringIO())
    found = diagnose(KIN, records, [c.T for c in cases])
    assert found[0].code == "offset_0054"
    assert "54.0 mm from the pose" in found[0].text


def test_the_missing_gripper_frame_correction_is_named(cases: list[Case], tmp_path: Path) -> None:
    from kr210_sim.sandbox.user_ik import load_ik

    src = (Path(__file__).resolve().parents[2] / "examples" / "ik_dh.py").read_text()
    line = "    R0_G = T[:3, :3] @ R_CORR"
    assert src.count(line) == 1
    path = tmp_path / "ik_no_correction.py"
    path.write_text(src.replace(line, "    R0_G = T[:3, :3]"))  # the URDF frame taken as DH's
    spec = f"{path}:solve"
    records = check(KIN, UserIk(spec, load_ik(spec).function), cases, io.StringIO())
    found = diagnose(KIN, records, [c.T for c in cases])
    assert found[0].code == "gripper_frame"
    assert found[0].text.startswith("every answer's orientation is off by the same rotation, 180.0")


def test_a_fixed_frame_rotation_is_named_with_its_angle(cases: list[Case]) -> None:
    X = _rz(0.3)  # the student solves for the pose turned by a fixed 0.3 rad about its z

    def turned(T: np.ndarray, q: np.ndarray) -> np.ndarray:
        return kinematics.nearest(T @ X, q)

    records = check(KIN, UserIk("t:s", turned), cases, io.StringIO())
    found = diagnose(KIN, records, [c.T for c in cases])
    assert [f.code for f in found][:1] == ["gripper_frame"]
    assert "17.2 deg about [0.0, 0.0, 1.0]" in found[0].text
    # A rotation error that varies from answer to answer is not "fixed".
    rng = np.random.default_rng(0)

    def wobbly(T: np.ndarray, q: np.ndarray) -> np.ndarray:
        return kinematics.nearest(T @ _rz(rng.uniform(0.1, 0.5)), q)

    assert "gripper_frame" not in _codes(cases, wobbly)


def test_wrist_flips_and_2pi_jumps_are_named(cases: list[Case]) -> None:
    def flipped(T: np.ndarray, q: np.ndarray) -> np.ndarray:
        a = kinematics.nearest(T, q).copy()
        a[3], a[4], a[5] = a[3] + math.pi, -a[4], a[5] + math.pi  # the other wrist solution
        return a

    assert "wrist_flip" in _codes(cases, flipped)
    failed = (
        {"cycle": 3, "detail": "approach line sample 4 [..]: t:s moves joint_1 ...: 2pi jump"},
    )
    codes = _codes(cases, kinematics.nearest, failed)
    assert codes == ["two_pi"]


def test_answers_outside_the_limits_raises_and_nones_are_counted(cases: list[Case]) -> None:
    def outside(T: np.ndarray, q: np.ndarray) -> Any:
        a = kinematics.nearest(T, q).copy()
        if a[0] > 0.5:
            raise ZeroDivisionError("atan2 by hand")
        if a[0] < -0.5:
            return None
        a[4] = 3.0  # past joint_5's 125 deg, no twin inside
        return a

    records = check(KIN, UserIk("t:s", outside), cases, io.StringIO())
    found = {f.code: f.text for f in diagnose(KIN, records, [c.T for c in cases])}
    assert set(found) == {"outside_limits", "raised", "none"}
    n_out = sum(r["q"] is not None and not r["within_limits"] for r in records)
    assert found["outside_limits"].startswith(f"{n_out} answers lie outside the joint limits")
    assert "ZeroDivisionError: atan2 by hand" in found["raised"]


def test_unusable_answers_are_named_with_what_to_do(cases: list[Case]) -> None:
    """NaN, a generator, a dict, the wrong shape: every answer unusable gave no finding."""
    n = len(cases)
    for fn, start in (
        (lambda T, q: [float("nan")] * 6, f"{n} of {n} answers are NaN or inf (e.g. IK_debug"),
        (lambda T, q: (x for x in q), f"{n} of {n} answers are not numbers (e.g. IK_debug"),
        (lambda T, q: {"q": list(q)}, f"{n} of {n} answers are not numbers"),
        (lambda T, q: [0.0] * 5, f"{n} of {n} answers do not hold six angles"),
    ):
        records = check(KIN, UserIk("t:s", fn), cases, io.StringIO())
        found = diagnose(KIN, records, [c.T for c in cases])
        assert [f.code for f in found] == ["unusable"], found
        assert found[0].text.startswith(start), found[0].text
    text = _texts(cases, lambda T, q: [float("nan")] * 6)[0]
    assert "returned NaN or inf for joint_1, joint_2" in text and "acos or asin" in text
    generator = _texts(cases, lambda T, q: (x for x in q))[0]
    assert "returned generator, not six numbers" in generator and "six floats [rad]" in generator

    def some_nan(T: np.ndarray, q: np.ndarray) -> Any:  # most answers right, a few NaN
        a = kinematics.nearest(T, q)
        return [math.nan] * 6 if a[0] > 1.0 else a

    bad = sum(kinematics.nearest(c.T, c.q_ref)[0] > 1.0 for c in cases)
    assert 0 < bad < n
    assert _texts(cases, some_nan)[0].startswith(f"{bad} of {n} answers are NaN or inf")


def _texts(cases: list[Case], fn: Callable[..., Any]) -> list[str]:
    records = check(KIN, UserIk("t:s", fn), cases, io.StringIO())
    return [f.text for f in diagnose(KIN, records, [c.T for c in cases])]


def _rpy_rotation(T: np.ndarray, order: str) -> np.ndarray:
    """T's rotation rebuilt from tf's roll, pitch and yaw with the elementary rotations
    multiplied in ``order`` (left to right), as a student wrote it."""
    from kr210_sim.exercise import tf_transformations as tft

    angles = dict(zip("xyz", tft.euler_from_matrix(T), strict=True))
    R = np.eye(3)
    for axis in order:
        R = (
            R
            @ tft.rotation_matrix(
                angles[axis], {"x": (1, 0, 0), "y": (0, 1, 0), "z": (0, 0, 1)}[axis]
            )[:3, :3]
        )
    return R


def test_an_euler_order_mistake_is_named_with_the_order(cases: list[Case]) -> None:
    """Positions exact, orientations off where the order matters: Rx Ry Rz for Rz Ry Rx."""

    def solve(T: np.ndarray, q: np.ndarray) -> Any:
        wrong = T.copy()
        wrong[:3, :3] = _rpy_rotation(T, "xyz")
        return kinematics.nearest(wrong, q)

    records = check(KIN, UserIk("test:solve", solve), cases, io.StringIO())
    found = diagnose(KIN, records, [c.T for c in cases])
    assert found[0].code == "euler_order"
    assert "positions exact, orientations off by up to" in found[0].text
    assert "(yours is Rx(roll) Ry(pitch) Rz(yaw); tf's euler_from_quaternion" in found[0].text


def test_a_rotation_overwritten_after_the_first_pose_is_named(cases: list[Case]) -> None:
    """Every answer has the first pose's orientation, as ``R = R.subs(...)`` in the loop."""
    first: list[np.ndarray] = []

    def solve(T: np.ndarray, q: np.ndarray) -> Any:
        first.append(T[:3, :3].copy()) if not first else None
        stale = T.copy()
        stale[:3, :3] = first[0]
        return kinematics.nearest(stale, q)

    records = check(KIN, UserIk("test:solve", solve), cases, io.StringIO())
    found = diagnose(KIN, records, [c.T for c in cases])
    assert found[0].code == "stale_rotation"
    assert (
        "with the orientation of an earlier pose (e.g. IK_debug case 2 has IK_debug case 1's)"
        in found[0].text
    )


def test_the_servers_mistakes_and_python_2s_notes_are_named(cases: list[Case]) -> None:
    """A NameError, complex numbers, unevaluated sympy expressions (the answers a ROS-form
    server gives, exercise/answers.py) and the notes of its process."""
    import sympy

    from kr210_sim.exercise.answers import angles
    from kr210_sim.exercise.messages import JointTrajectoryPoint

    some = cases[:6]

    def answer(i: int) -> Any:
        if i < 2:
            return angles(JointTrajectoryPoint(positions=[0, complex(1, 0.2), 0, 0, 0, 0]))
        if i < 4:
            return angles(JointTrajectoryPoint(positions=[sympy.Symbol("q1")] + [0] * 5))
        raise NameError("name 'theta4' is not defined (IK_server.py line 88)")

    from kr210_sim.grading.ikcheck import case_record
    from kr210_sim.sandbox.ik_guard import assess

    records = []
    for i, c in enumerate(some):
        try:
            raw = answer(i)
        except NameError as exc:
            raw = exc
        records.append(case_record(KIN, c, assess(KIN, c.T, c.q_ref, raw)))
    note = "IK_server.py line 16: `303/1000` divides integers (303 / 1000 = 0 under Python 2)"
    found = {f.code: f.text for f in diagnose(KIN, records, [c.T for c in some], notes=[note])}
    assert found["name_error"].startswith(
        "NameError: name 'theta4' is not defined (IK_server.py line 88) on 2 of 6 poses"
    )
    assert found["complex"].startswith(
        "2 of 6 answers hold a complex number (e.g. IK_debug case 1: joint_2 = 1+0.2j)"
    )
    assert "(e.g. IK_debug case 3: joint_1 = q1 has free symbols q1)" in found["unevaluated"]
    assert found["python2"] == f"under Python 2, as under ROS, the code computed otherwise: {note}"
    assert "unusable" not in found  # named above, not as "not numbers"


def _wrist_for(q123: np.ndarray, R: np.ndarray, start: np.ndarray) -> np.ndarray:
    """Joints 4-6 that give orientation ``R`` with joints 1-3 at ``q123`` (Gauss-Newton on our
    forward kinematics), as a student's theta4-6 from R0_3 and R3_6 give them."""
    w = start.astype(float).copy()

    def err(w: np.ndarray) -> np.ndarray:
        return (KIN.forward(np.r_[q123, w])[:3, :3] - R).ravel()

    for _ in range(30):
        e = err(w)
        J = np.array([(err(w + 1e-7 * np.eye(3)[k]) - e) / 1e-7 for k in range(3)]).T
        w -= np.linalg.lstsq(J, e, rcond=None)[0]
    return w


def test_theta4_to_6_wrong_with_the_wrist_centre_right_is_named(cases: list[Case]) -> None:
    """R0_3 evaluated at (theta1, theta3, theta3): the wrist centre right, the orientation not."""

    def solve(T: np.ndarray, q: np.ndarray) -> Any:
        good = kinematics.nearest(T, q)
        return np.r_[good[:3], good[3:] + np.array([0.4, -0.3, 0.2])]

    found = diagnose(
        KIN, check(KIN, UserIk("t:s", solve), cases, io.StringIO()), [c.T for c in cases]
    )
    assert found[0].code == "wrist_angles"
    n = int(found[0].text.split()[0])  # those inside the limits (the others are named so)
    assert n > 0.9 * len(cases)
    assert f"{n} of {len(cases)} answers put the wrist centre" in found[0].text
    assert "theta1-3 are right and theta4-6 are not" in found[0].text


def test_the_drop_s_correction_with_the_wrong_sign_is_named(cases: list[Case]) -> None:
    """theta3 = pi/2 - (b + atan2(a3, d4)) with a3 = -0.054: 0.072 rad too large, the wrist
    angles found from that theta3 (the orientation right), the wrist centre 108 mm off."""
    sag = math.atan2(0.054, 1.5)

    def solve(T: np.ndarray, q: np.ndarray) -> Any:
        good = kinematics.nearest(T, q)
        q123 = good[:3] + np.array([0.0, 0.0, 2 * sag])
        return np.r_[q123, _wrist_for(q123, T[:3, :3], good[3:])]

    found = diagnose(
        KIN, check(KIN, UserIk("t:s", solve), cases, io.StringIO()), [c.T for c in cases]
    )
    assert found[0].code == "theta3_offset"
    assert "wrist centre 108 mm from where it belongs, the same on each" in found[0].text
    assert "theta3 is off by a constant 0.072 rad (4.1 deg), twice the drop's" in found[0].text


def test_a_stale_rotation_is_named_when_the_positions_miss_too(cases: list[Case]) -> None:
    """The rotation overwritten by the first pose's, and the wrist centre found from it: the
    positions miss as well (a stale R0_6 used for the wrist centre and for R3_6)."""
    first: list[np.ndarray] = []

    def solve(T: np.ndarray, q: np.ndarray) -> Any:
        first.append(T[:3, :3].copy()) if not first else None
        stale = T.copy()
        stale[:3, :3] = first[0]
        stale[0, 3] += 0.01  # and the position off besides
        try:
            return kinematics.nearest(stale, q)
        except UnreachablePoseError:
            return None

    found = diagnose(
        KIN, check(KIN, UserIk("t:s", solve), cases, io.StringIO()), [c.T for c in cases]
    )
    assert found[0].code == "stale_rotation"
    n, _, answered = found[0].text.split()[:3]
    assert int(n) == int(answered) - 1 > 0.7 * len(cases)  # all but the first pose's answer
    assert found[0].text.startswith(f"{n} of {answered} answers have the orientation")


def test_a_wrong_gripper_length_is_named_with_the_length_used(cases: list[Case]) -> None:
    """The wrist centre found 0.453 m behind gripper_link (the fingertips' distance), the
    orientation right: every answer stops 150 mm short along the gripper's axis."""

    def solve(T: np.ndarray, q: np.ndarray) -> Any:
        short = T.copy()
        short[:3, 3] -= 0.15 * T[:3, 0]
        try:
            return kinematics.nearest(short, q)
        except UnreachablePoseError:
            return None

    found = diagnose(
        KIN, check(KIN, UserIk("t:s", solve), cases, io.StringIO()), [c.T for c in cases]
    )
    assert found[0].code == "gripper_length"
    assert "stop 150 mm short of their pose along the gripper's axis" in found[0].text
    assert "found 0.453 m behind gripper_link, where it is 0.303 m" in found[0].text


def test_theta4_to_6_wrong_on_some_poses_only_is_named(cases: list[Case]) -> None:
    """R0_3.inv("LU") is R0_3's inverse on some poses and garbage on others (sympy's LU pivots on
    the round-off of R0_3's singular leading 2x2 block): about half the answers miss, each with
    the wrist centre right."""

    def solve(T: np.ndarray, q: np.ndarray) -> Any:
        good = kinematics.nearest(T, q)
        if int(abs(T[0, 3]) * 1000) % 2:
            return np.r_[good[:3], good[3:] + np.array([0.4, -0.3, 0.2])]
        return good

    found = diagnose(
        KIN, check(KIN, UserIk("t:s", solve), cases, io.StringIO()), [c.T for c in cases]
    )
    assert found[0].code == "wrist_angles"
    n = int(found[0].text.split()[0])
    assert 0.2 * len(cases) < n < 0.8 * len(cases)


def test_a_server_never_sent_q_ref_is_told_what_to_keep_instead(cases: list[Case]) -> None:
    """The other wrist solution than ours, for an original-form server (a request holds poses
    only): the advice is the previous pose's answer, not q_ref."""

    def flipped(T: np.ndarray, q: np.ndarray) -> Any:
        a = kinematics.nearest(T, q).copy()
        a[3], a[4], a[5] = a[3] + math.pi, -a[4], a[5] + math.pi
        return a

    records = check(KIN, UserIk("t:s", flipped), cases, io.StringIO())
    poses = [c.T for c in cases]
    ours = {f.code: f.text for f in diagnose(KIN, records, poses)}
    ros = {f.code: f.text for f in diagnose(KIN, records, poses, no_q_ref=True)}
    assert ours["wrist_flip"].endswith("return the one nearest q_ref")
    assert "keep the one nearest the previous pose's answer" in ros["wrist_flip"]
    assert "q_ref" not in ros["wrist_flip"]


def test_answers_that_fail_are_named_before_branch_changes_that_are_only_flagged(
    cases: list[Case],
) -> None:
    def mixed(T: np.ndarray, q: np.ndarray) -> Any:
        a = kinematics.nearest(T, q).copy()
        if int(abs(T[0, 3]) * 1000) % 2:
            a[3], a[4], a[5] = a[3] + math.pi, -a[4], a[5] + math.pi  # the other wrist: flagged
        else:
            a[4] = 3.0  # past joint_5's 125 deg: the case fails
        return a

    codes = _codes(cases, mixed)
    assert codes.index("outside_limits") < codes.index("wrist_flip")


def test_a_singular_wrist_taken_apart_from_rounding_noise_is_named(cases: list[Case]) -> None:
    """An IK right everywhere but at q5 = 0, where its q4 and q6 come out apart as the noise of
    atan2 gives them (here q4 + 1, q6 + 0.9: their sum 1.9 rad off), is named there."""

    def fn(T: np.ndarray, q_ref: np.ndarray) -> np.ndarray:
        q = kinematics.nearest(T, q_ref)
        if abs(math.sin(q[4])) < 1e-9:
            q = q.copy()
            q[3] += 1.0
            q[5] += 0.9
        return q

    records = check(KIN, UserIk("test:solve", fn), cases, io.StringIO())
    found = diagnose(KIN, records, [c.T for c in cases])
    assert [f.code for f in found] == ["singular_wrist"]
    text = found[0].text
    assert text.startswith("3 answers with the wrist straight (theta5 = 0, e.g. case q = 0: ")
    assert "theta4 = 1.0000, theta6 = 0.9000) reach the position" in text
    assert "the orientation off by up to 1900.0 mrad: there only theta4 + theta6 is defined" in text
