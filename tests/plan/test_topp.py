"""The time-optimal duration of a sampled path: against the closed form of one joint, its
scaling with the limits, and against toppra's TOPP-RA on a grid fine enough to converge."""

from __future__ import annotations

import numpy as np
import pytest

from kr210_sim.cell.spec import MotionConfig
from kr210_sim.plan.timing import blend, joint_min_time
from kr210_sim.plan.topp import time_optimal_duration
from kr210_sim.plan.trajectory import JointLimits
from kr210_sim.robot.description import load_robot

LIMITS = JointLimits.from_robot(load_robot(), MotionConfig())
#: A path through four waypoints that bends in every joint (timed through them by ruckig).
WAY = np.array(
    [
        [0.8, -0.2, 0.2, 0.0, 0.0, 0.0],
        [0.4, -0.5, 0.5, 0.3, -0.4, 0.2],
        [-0.1, -0.3, 0.1, -0.2, 0.3, -0.1],
        [-0.5, 0.1, -0.2, 0.1, 0.2, 0.3],
    ]
)


@pytest.mark.parametrize("distance", [0.02, 0.3, 1.0, 2.5])
@pytest.mark.parametrize("joint", [0, 1, 5])
def test_one_joint_alone_takes_its_closed_form_time(distance: float, joint: int) -> None:
    """Triangle (short) and trapezoid (long) velocity profiles."""
    q = np.zeros((80, 6))
    q[:, joint] = np.linspace(0.0, distance, 80)
    exact = joint_min_time(np.array([distance]), LIMITS.v_max[[joint]], LIMITS.a_max[[joint]])
    assert time_optimal_duration(q, LIMITS.v_max, LIMITS.a_max) == pytest.approx(exact[0], rel=2e-4)


def test_the_time_scales_with_the_limits() -> None:
    """Velocity limits times k and acceleration limits times k^2: the same path in 1/k of the
    time; repeated states change nothing."""
    q = blend(WAY, LIMITS).sample_many(np.linspace(0.0, 2.0, 120))[0]
    t = time_optimal_duration(q, LIMITS.v_max, LIMITS.a_max)
    assert time_optimal_duration(q, 2.0 * LIMITS.v_max, 4.0 * LIMITS.a_max) == pytest.approx(t / 2)
    assert time_optimal_duration(np.repeat(q, 2, axis=0), LIMITS.v_max, LIMITS.a_max) == t
    assert time_optimal_duration(q[:1], LIMITS.v_max, LIMITS.a_max) == 0.0


def test_it_agrees_with_toppra_on_a_fine_grid_and_bounds_the_timed_path() -> None:
    ta = pytest.importorskip("toppra")
    traj = blend(WAY, LIMITS)
    q = traj.sample_many(np.linspace(0.0, traj.duration, 400))[0]
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(q, axis=0), axis=1))])
    path = ta.SplineInterpolator(s / s[-1], q)
    v = ta.constraint.JointVelocityConstraint(np.column_stack([-LIMITS.v_max, LIMITS.v_max]))
    a = ta.constraint.JointAccelerationConstraint(np.column_stack([-LIMITS.a_max, LIMITS.a_max]))
    grid = np.linspace(0.0, 1.0, 801)
    algo = ta.algorithm.TOPPRA([v, a], path, gridpoints=grid, parametrizer="ParametrizeConstAccel")
    theirs = algo.compute_trajectory(0, 0).duration
    ours = time_optimal_duration(q, LIMITS.v_max, LIMITS.a_max)
    assert ours == pytest.approx(theirs, rel=0.01)
    coarse = traj.sample_many(np.linspace(0.0, traj.duration, 80))[0]
    bound = time_optimal_duration(coarse, LIMITS.v_max, LIMITS.a_max)
    assert 0.97 * ours < bound <= ours < traj.duration
