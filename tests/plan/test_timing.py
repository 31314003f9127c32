"""Timing through waypoints without stopping, and the lower bounds of a move's duration."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from kr210_sim.cell.spec import MotionConfig
from kr210_sim.errors import PlanningError
from kr210_sim.plan.timing import (
    blend,
    check_limits,
    joint_min_time,
    path_bound,
    rest_to_rest_bound,
    time_path,
)
from kr210_sim.plan.trajectory import JointLimits, Trajectory, plan_ptp
from kr210_sim.robot.description import load_robot

WAY = np.array(
    [
        [0.8, -0.2, 0.2, 0.0, 0.0, 0.0],
        [0.4, -0.5, -0.3, 0.3, 0.2, -0.4],
        [0.0, -0.4, -0.6, 0.5, 0.4, -0.8],
        [-0.3, 0.1, -0.2, 0.2, 0.1, -0.3],
    ]
)


@pytest.fixture(scope="module")
def limits() -> JointLimits:
    return JointLimits.from_robot(load_robot(), MotionConfig())


def test_joint_min_time_golden() -> None:
    v, a = np.array([2.0, 2.0]), np.array([4.0, 4.0])
    # 1 rad reaches full speed exactly (v^2/a): 0.5 s accelerating + 0.5 s braking
    assert joint_min_time(np.array([1.0, 3.0]), v, a) == pytest.approx([1.0, 2.0])
    assert joint_min_time(np.array([0.25, 0.0]), v, a) == pytest.approx([0.5, 0.0])


def test_rest_to_rest_bound_is_below_ruckigs_time(limits: JointLimits) -> None:
    rng = np.random.default_rng(1)
    ratios = []
    for _ in range(50):
        q0, q1 = rng.uniform(-0.7, 0.7, (2, 6))
        bound = rest_to_rest_bound(q0, q1, limits)
        ratios.append(plan_ptp(q0, q1, limits).duration / bound)
    assert min(ratios) >= 1.0 and max(ratios) < 1.5


def test_blended_path_passes_its_waypoints_without_stopping(limits: JointLimits) -> None:
    traj = blend(WAY, limits)
    rest = blend(WAY, limits, 0.0)
    assert traj.duration < 0.95 * rest.duration
    for i, t in enumerate(traj.starts):  # type: ignore[attr-defined]
        q, qd, _ = traj.sample(float(t) + 1e-9)
        assert np.allclose(q, WAY[i], atol=1e-6)
        if i > 0:
            assert np.abs(qd).max() > 0.05  # moving through the waypoint
    assert np.allclose(traj.q_end, WAY[-1])
    v, a = check_limits(traj, limits)
    assert 0.5 < v <= 1.0 + 1e-6 and 0.5 < a <= 1.0 + 1e-6
    qs = traj.sample_many(np.linspace(0, traj.duration, 200))[0]
    bound = path_bound(qs, limits)
    assert 0.5 * traj.duration < bound <= traj.duration


def test_the_limit_check_catches_a_too_fast_path(limits: JointLimits) -> None:
    slow = JointLimits(limits.lower, limits.upper, limits.v_max / 2, limits.a_max, limits.j_max)
    with pytest.raises(PlanningError, match="of the velocity limit"):
        check_limits(blend(WAY, limits), slow)


def test_a_rejected_blend_falls_back_to_the_straight_segments(limits: JointLimits) -> None:
    def only_rest(traj: Trajectory) -> bool:  # accept only paths on the straight segments
        qs = traj.sample_many(np.linspace(0, traj.duration, 400))[0]
        for q in qs:
            dist = []
            for a, b in itertools.pairwise(WAY):
                u = np.clip(np.dot(q - a, b - a) / np.dot(b - a, b - a), 0, 1)
                dist.append(np.linalg.norm(a + u * (b - a) - q))
            if min(dist) > 1e-6:
                return False
        return True

    traj, scale = time_path(WAY, limits, only_rest)
    assert scale == 0.0 and only_rest(traj)
    blended, scale = time_path(WAY, limits, lambda t: True)
    assert scale == 1.0 and blended.duration < traj.duration
