"""A ROS-form server's answers are judged from the joint state it was never sent: each angle is
taken at its 2 pi twin nearest the robot's joints (MoveIt's CalculateIK request held poses
only, so a student's atan2 answers lie in (-pi, pi] whatever the arm's joints were)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pytest

from kr210_sim.errors import IkFailedError
from kr210_sim.robot.description import load_robot
from kr210_sim.robot.kinematics import Kinematics
from kr210_sim.sandbox.ik_guard import MAX_LINE_STEP, CheckedIk, assess
from kr210_sim.sandbox.user_ik import UserIk

KIN = Kinematics(load_robot())
TWO_PI = 2 * math.pi
#: The arm with joint_4 past pi (its limits are +-350 deg).
Q = np.array([0.3, 0.2, -0.1, 3.5, 0.6, -0.4])


def _atan2_range(q: np.ndarray) -> list[float]:
    """``q`` as a student's atan2 gives it: every angle in (-pi, pi]."""
    return [math.atan2(math.sin(v), math.cos(v)) for v in q]


def test_an_answer_a_turn_away_is_taken_at_its_twin_for_a_server_never_sent_q_ref() -> None:
    T = KIN.forward(Q)
    raw = _atan2_range(Q)  # joint_4 = 3.5 - 2 pi
    ours = assess(KIN, T, Q, raw)
    assert ours.passed and ours.q is not None and ours.max_move == pytest.approx(TWO_PI)
    ros = assess(KIN, T, Q, raw, no_q_ref=True)
    assert ros.passed and ros.q is not None
    np.testing.assert_allclose(ros.q, Q, atol=1e-12)
    assert ros.wrapped == (3,) and ros.max_move == pytest.approx(0.0, abs=1e-12)
    # an angle whose twins all leave the limits stays as it is (joint_2: -45..85 deg)
    q = Q.copy()
    q[1] = 1.2
    kept = assess(KIN, KIN.forward(q), q + 0.5, list(q), no_q_ref=True)
    assert kept.q is not None and kept.q[1] == pytest.approx(1.2)


def test_a_straight_line_of_a_ros_form_server_is_walked_on_the_twins() -> None:
    """The same answers fail a line for an IK sent q_ref (ours: it should have used it) and pass
    it for a ROS-form server (one request of poses, no joint state)."""
    samples = [Q + np.array([0.0, 0.0, 0.0, 0.004 * i, 0.0, 0.0]) for i in range(5)]
    poses = [KIN.forward(q) for q in samples]

    def solve(T: np.ndarray, q_ref: np.ndarray) -> list[float]:  # one branch, whatever q_ref
        return _atan2_range(KIN.nearest(T, Q))

    def batch(Ts: Sequence[np.ndarray]) -> list[list[float]]:
        return [solve(T, np.zeros(6)) for T in Ts]

    ours = CheckedIk(UserIk("ours:solve", solve), KIN)
    with pytest.raises(IkFailedError, match="2pi jump"):
        ours.line_ik("approach line")(poses[1], samples[0])
    ros = CheckedIk(UserIk("IK_server.py:handle_calculate_IK", solve, batch=batch), KIN)
    ros.prefetch(poses)
    ik = ros.line_ik("approach line")
    q = samples[0]
    for T, want in zip(poses[1:], samples[1:], strict=True):
        q = ik(T, q)
        assert float(np.max(np.abs(q - want))) < MAX_LINE_STEP / 10


def test_answers_turns_away_are_taken_at_their_twin_and_noise_is_not() -> None:
    """A server keeping each answer near the previous one drifts by turns over a request of
    unrelated poses (ik-check's); the drift is taken back, a non-number-like 1e300 is not."""
    T = KIN.forward(Q)
    drifted = list(Q + np.array([0.0, 0.0, 0.0, 2 * TWO_PI, 0.0, -3 * TWO_PI]))
    a = assess(KIN, T, Q, drifted, no_q_ref=True)
    assert a.passed and a.q is not None and a.wrapped == (3, 5)
    np.testing.assert_allclose(a.q, Q, atol=1e-9)
    assert not assess(KIN, T, Q, drifted).passed  # ours: two turns outside the limits stays
    huge = list(Q)
    huge[5] = 1e300
    h = assess(KIN, T, Q, huge, no_q_ref=True)
    assert not h.passed and h.q is not None and h.q[5] == 1e300
