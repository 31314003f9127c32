"""Loading a user's IK from a SPEC, and judging its answers (ik_plugin)."""

from __future__ import annotations

import math
import os
import pickle
import re
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from kr210_sim.cell.spec import MotionConfig
from kr210_sim.errors import ConfigError, IkFailedError, IkSpecError, UnreachablePoseError
from kr210_sim.plan.planner import Planner
from kr210_sim.robot import kinematics
from kr210_sim.robot.description import load_robot
from kr210_sim.sandbox.ik_guard import (
    MAX_LINE_STEP,
    CheckedIk,
    assess,
    branch_change,
    call_timed,
    into_limits,
)
from kr210_sim.sandbox.user_ik import UserIk, load_ik

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "ik_dh.py"
KIN = kinematics.committed()
Q = np.array([0.3, 0.2, -0.3, 0.5, 0.6, -0.4])


def _file(tmp_path: Path, text: str, name: str = "my_ik.py") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


# ----------------------------------------------------------------------------- loading
def test_module_and_file_specs_load(tmp_path: Path) -> None:
    ours = load_ik("kr210_sim.robot.kinematics:nearest")
    assert ours.function is kinematics.nearest and ours.spec == "kr210_sim.robot.kinematics:nearest"
    worked = load_ik(f"{EXAMPLE}:solve")
    T = kinematics.forward(Q)
    np.testing.assert_allclose(worked.function(T, Q), Q, atol=1e-9)


def test_a_file_may_import_its_neighbours(tmp_path: Path) -> None:
    _file(tmp_path, "SCALE = 2.0\n", "helper_for_ik.py")
    path = _file(
        tmp_path, "from helper_for_ik import SCALE\ndef solve(T, q):\n    return [SCALE] * 6\n"
    )
    assert load_ik(f"{path}:solve").function(None, None) == [2.0] * 6


def test_user_ik_pickles_as_its_spec_and_is_rebuilt(tmp_path: Path) -> None:
    path = _file(tmp_path, "CALLS = []\ndef solve(T, q):\n    return list(q)\n")
    ik = load_ik(f"{path}:solve")
    data = pickle.dumps(ik)
    assert str(path).encode() in data and b"CALLS" not in data  # the string travels
    load_ik.cache_clear()  # as in a fresh worker process
    rebuilt = pickle.loads(data)
    assert rebuilt.spec == ik.spec and rebuilt.function is not ik.function
    assert rebuilt.function(None, [1, 2, 3, 4, 5, 6]) == [1, 2, 3, 4, 5, 6]


@pytest.mark.parametrize(
    ("source", "function", "message"),
    [
        (None, "solve", "no such file"),
        ("def solve(T, q):\n    return (\n", "solve", "syntax error in"),
        ("raise RuntimeError('no numpy here')\n", "solve", "raised RuntimeError: no numpy here"),
        ("import sys\nsys.exit(3)\n", "solve", "raised SystemExit: 3"),
        (
            "def helper():\n    pass\ndef solv(T, q):\n    pass\n",
            "solve",
            "(it defines: helper, solv)",
        ),
        ("solve = 42\n", "solve", "is a int, not a function"),
        ("import not_a_module_anyone_has\n", "solve", "No module named 'not_a_module_anyone_has'"),
        ("def solve(T, q):\n    pass\n", "1solve", "is not a Python function name"),
    ],
)
def test_bad_file_specs_are_one_line(
    tmp_path: Path, source: str | None, function: str, message: str
) -> None:
    path = tmp_path / "bad_ik.py"
    if source is not None:
        path.write_text(source)
    with pytest.raises(IkSpecError) as exc:
        load_ik(f"{path}:{function}")
    text = str(exc.value)
    assert message in text, text
    assert "\n" not in text and isinstance(exc.value, ConfigError)


def test_a_syntax_error_names_the_line(tmp_path: Path) -> None:
    path = _file(tmp_path, "import math\n\ndef solve(T, q)\n    return q\n")
    with pytest.raises(IkSpecError, match=r"line 3: expected ':'"):
        load_ik(f"{path}:solve")


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("no_such_package.ik:solve", "no module named 'no_such_package'"),
        ("kr210_sim.no_such_module:solve", "no module named 'kr210_sim.no_such_module'"),
        ("kr210_sim.robot.kinematics:no_such", "has no function 'no_such'"),
        ("kr210_sim.robot.kinematics:TWO_PI", "is a float, not a function"),
        ("kr210_sim.robot.kinematics", "expected package.module:function"),
        (":solve", "expected package.module:function"),
        ("/no/such/ik.py", "--ik '/no/such/ik.py': no such file or folder /no/such/ik.py"),
        ("no_such_ik.py", "--ik 'no_such_ik.py': no such file or folder no_such_ik.py"),
    ],
)
def test_bad_module_specs(spec: str, message: str) -> None:
    with pytest.raises(IkSpecError, match=re.escape(message)):
        load_ik(spec)


# ----------------------------------------------------------------------------- judging
class _NeedsGrad:
    """Stands for a tensor that needs grad: ``float()`` and ``__array__`` raise RuntimeError."""

    def __float__(self) -> float:
        raise RuntimeError("needs grad")

    def __array__(self, dtype: Any = None, copy: Any = None) -> np.ndarray:
        raise RuntimeError("needs grad")


def test_a_correct_answer_passes_with_exact_errors() -> None:
    T = kinematics.forward(Q)
    a = assess(KIN, T, Q, list(Q))
    assert a.passed and a.within_limits and a.wrapped == ()
    assert a.position_error < 1e-12 and a.orientation_error < 1e-12 and a.max_move == 0.0


@pytest.mark.parametrize(
    ("raw", "problem"),
    [
        (ValueError("math domain error"), "raised ValueError: math domain error"),
        (None, "returned None"),
        ([0.1] * 5, "returned shape (5,), not six angles"),
        ([[0.1] * 6] * 2, "returned shape (2, 6)"),
        ("abcdef", "returned str, not six numbers"),
        ([0.3, 0.2, math.nan, 0.5, 0.6, -0.4], "returned NaN or inf for joint_3"),
        ([0.3, 1.6, -0.3, 0.5, 0.6, -0.4], "returned joint_2 = 91.7 deg, outside its limits"),
        # Values that raise on float(), as a tensor that needs grad does: unusable, not a crash.
        ([_NeedsGrad()] * 6, "returned list, not six numbers (RuntimeError: needs grad)"),
        (_NeedsGrad(), "returned _NeedsGrad, not six numbers (RuntimeError: needs grad)"),
        # Far outside the limits: no 2 pi "twin" brings 1e300 rad back (rounding noise).
        ([1e300] * 6, "returned joint_1 = 5.73e+301 deg, outside its limits"),
        ([0.0, 0.0, 0.0, 3.0 + 4 * math.pi, 0.0, 0.0], "returned joint_4 = 891.9 deg, outside"),
    ],
)
def test_unusable_answers(raw: Any, problem: str) -> None:
    a = assess(KIN, kinematics.forward(Q), Q, raw)
    assert not a.passed
    assert problem in a.problem, a.problem
    assert (a.error != "") == isinstance(raw, BaseException)


def test_errors_are_measured_against_our_forward_kinematics() -> None:
    T = kinematics.forward(Q)
    # joint_6 turns about the gripper's x axis through gripper_link: orientation only.
    a = assess(KIN, T, Q, Q + np.array([0, 0, 0, 0, 0, 0.002]))
    assert a.position_error < 1e-12
    assert a.orientation_error == pytest.approx(0.002, rel=1e-9)
    assert not a.passed and "2 mrad" in a.problem
    assert assess(KIN, T, Q, Q + np.array([0, 0, 0, 0, 0, 0.0005])).passed  # 0.5 mrad: fine
    # joint_1 by 1 mrad moves gripper_link about its axis: |p_xy| * 1e-3
    b = assess(KIN, T, Q, Q + np.array([0.001, 0, 0, 0, 0, 0]))
    r = float(np.hypot(*T[:2, 3]))
    assert b.position_error == pytest.approx(r * 0.001, rel=1e-6)
    assert b.orientation_error == pytest.approx(0.001, rel=1e-6)
    wc = T[:3, 3] - KIN.geometry.dg * T[:3, 0]
    assert b.wrist_centre_error == pytest.approx(np.hypot(*wc[:2]) * 0.001, rel=1e-6)


def test_twins_outside_the_limits_are_wrapped_inside_and_others_kept() -> None:
    T = kinematics.forward(Q)
    q = Q + np.array([-2 * math.pi, 0, 0, 0, 0, 0])  # q1 = -344 deg: outside [-185, 185]
    a = assess(KIN, T, Q, q)
    assert a.passed and a.wrapped == (0,)
    np.testing.assert_allclose(a.q, Q, atol=1e-12)
    kept = Q + np.array([0, 0, 0, -2 * math.pi, 0, 0])  # q4 = -331 deg: inside [-350, 350]
    b = assess(KIN, T, Q, kept)
    assert b.passed and b.wrapped == ()
    assert b.max_move == pytest.approx(2 * math.pi) and b.max_move_joint == 3
    # q3 = 65 deg + 5 deg has no twin inside [-210, 65]: outside
    q3 = Q.copy()
    q3[2] = math.radians(70)
    assert into_limits(KIN, q3, Q)[1] == ()


def test_of_two_twins_inside_the_limits_the_one_nearest_q_ref_is_taken() -> None:
    ref = np.array([0.0, 0, 0, 3.0, 0, 0])
    q = np.array([0.0, 0, 0, 3.0 + 2 * math.pi, 0, 0])  # 1 turn out: twins 3.0 and 3.0 - 2 pi
    out, moved = into_limits(KIN, q, ref)
    assert moved == (3,) and out[3] == pytest.approx(3.0)
    for v in (-3.0 - 2 * math.pi, -3.0 + 4 * math.pi):
        assert into_limits(KIN, np.array([0.0, 0, 0, v, 0, 0]), -ref)[0][3] == pytest.approx(-3.0)


def test_only_angles_within_one_turn_of_the_limits_are_brought_back() -> None:
    zero = np.zeros(6)
    for far in (1e300, -1e300, 3.0 + 4 * math.pi, math.radians(350) + 2 * math.pi + 1e-3):
        q = np.array([0.0, 0, 0, far, 0, 0])
        out, moved = into_limits(KIN, q, zero)
        assert moved == () and out[3] == far
    a = assess(KIN, kinematics.forward(zero), zero, [1e300] * 6)  # was passed as the zero pose
    assert not a.passed and a.q is not None and not a.within_limits


def test_branch_changes_are_named() -> None:
    assert branch_change(Q, Q + 0.05) == ""
    assert branch_change(Q + np.array([0, 0, 0, 2 * math.pi, 0, 0]), Q) == "2pi jump"
    flipped = Q + np.array([0, 0, 0, math.pi, 0, math.pi])
    flipped[4] = -Q[4]
    assert branch_change(flipped, Q) == "wrist flip"
    assert branch_change(Q + np.array([0, 0.3, -0.5, 0, 0, 0]), Q) == "arm branch change"
    singular = np.array([0.3, 0.2, -0.3, 1.5, 0.0, -1.4])
    assert branch_change(singular, np.array([0.3, 0.2, -0.3, 0.5, 0.0, -0.4])) == "q4/q6 split"


def test_call_timed_passes_copies_and_returns_exceptions() -> None:
    def vandal(T: np.ndarray, q: np.ndarray) -> None:
        T[:] = 0.0
        q[:] = 0.0
        raise KeyError("boom")

    T = kinematics.forward(Q)
    before = T.copy()
    out, dt = call_timed(vandal, T, Q.copy())
    assert isinstance(out, KeyError) and dt >= 0.0
    np.testing.assert_array_equal(T, before)


# ----------------------------------------------------------------------------- the planner's view
def _checked(fn: Callable[..., Any], spec: str = "test:solve") -> CheckedIk:
    return CheckedIk(UserIk(spec, fn), KIN)


def test_checked_ik_counts_calls_and_reports_the_pose() -> None:
    ik = _checked(lambda T, q: kinematics.nearest(T, q) + 0.01)
    T = kinematics.forward(Q)
    with pytest.raises(IkFailedError) as exc:
        ik.solve(T, Q, "standoff pose")
    text = str(exc.value)
    assert text.startswith(f"standoff pose {np.round(T[:3, 3], 3).tolist()}: test:solve returned q")
    assert "misses the pose by" in text
    ok = _checked(kinematics.nearest)
    for _ in range(3):
        np.testing.assert_allclose(ok.solve(T, Q, "x"), Q, atol=1e-12)
    s = ok.summary()
    assert s["spec"] == "test:solve" and s["calls"] == 3
    t = s["wall_time_s"]
    assert 0 < t["per_call_mean"] <= t["per_call_max"] <= t["total"]


def test_none_is_unreachable_only_when_it_is() -> None:
    ik = _checked(lambda T, q: None)
    with pytest.raises(IkFailedError, match=r"returned None .* but the pose is reachable"):
        ik.solve(kinematics.forward(Q), Q, "grasp pose")
    far = np.eye(4)
    far[:3, 3] = (5.0, 0.0, 1.0)
    with pytest.raises(UnreachablePoseError, match="out of reach"):
        ik.solve(far, Q, "grasp pose")


def test_line_samples_may_not_jump_branch() -> None:
    def flipper(T: np.ndarray, q_ref: np.ndarray) -> np.ndarray:
        q = kinematics.nearest(T, q_ref)
        return q + np.array([0, 0, 0, math.pi, -2 * q[4], math.pi])  # the other wrist

    T = kinematics.forward(Q)
    line = _checked(flipper).line_ik("lift line")
    with pytest.raises(IkFailedError) as exc:
        line(T, Q)
    text = str(exc.value)
    assert text.startswith("lift line sample 1 ") and "wrist flip" in text
    assert f"limit {MAX_LINE_STEP} rad per sample" in text
    # the same answer for a point-to-point target is fine (any branch may be approached)
    q = _checked(flipper).solve(T, Q, "standoff pose")
    assert abs(q[3] - Q[3]) == pytest.approx(math.pi)


def test_planner_with_our_ik_as_a_plug_in_plans_the_same_moves() -> None:
    robot, motion = load_robot(), MotionConfig()
    ours = Planner(robot, motion)
    plugged = Planner(
        robot, motion, UserIk("kr210_sim.robot.kinematics:nearest", kinematics.nearest)
    )
    target, radius = (2.6, 0.9, 0.914 + 0.125), 0.05
    a = ours.plan_grasp(ours.ready_q, target, radius)
    b = plugged.plan_grasp(plugged.ready_q, target, radius)
    for m1, m2 in ((a.approach_lin, b.approach_lin), (a.lift, b.lift), (a.retreat, b.retreat)):
        np.testing.assert_array_equal(m1.trajectory.q_knots, m2.trajectory.q_knots)  # type: ignore[attr-defined]
    np.testing.assert_array_equal(a.approach_ptp.q_end, b.approach_ptp.q_end)
    assert plugged.user_ik is not None and plugged.user_ik.stats.calls > 10


def test_the_identity_of_a_fifo_named_like_a_module_is_none_at_once(tmp_path: Path) -> None:
    """An IK's identity hashes only a regular file: a FIFO ``ik.py`` has none (its whole-file
    read waited for a writer forever)."""
    os.mkfifo(tmp_path / "ik.py")
    code = (
        "import sys; from kr210_sim.sandbox.user_ik import ik_identity; "
        "print(ik_identity(sys.argv[1]))"
    )
    done = subprocess.run(
        [sys.executable, "-c", code, f"{tmp_path / 'ik.py'}:solve"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.stdout == "{'function': 'solve', 'sha256': None}\n", done.stderr
