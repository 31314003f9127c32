"""Trajectories: limits at every sample, continuity, and the straight-line property."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from kr210_sim.cell.spec import MotionConfig
from kr210_sim.errors import PlanningError
from kr210_sim.plan.trajectory import JointLimits, Trajectory, plan_cartesian_line, plan_ptp
from kr210_sim.robot import kinematics as kin
from kr210_sim.robot.description import load_robot

LIMITS = JointLimits.from_robot(load_robot(), MotionConfig())
DT = 0.002


@dataclass(frozen=True, slots=True)
class TrajectoryStats:
    """Worst values of a trajectory sampled every ``dt``.

    Attributes:
        duration: Duration [s].
        velocity_ratio: max |qd| / v_max over joints and samples.
        acceleration_ratio: max |qdd| / a_max over joints and samples.
        max_step: Largest joint change between consecutive samples [rad].
    """

    duration: float
    velocity_ratio: float
    acceleration_ratio: float
    max_step: float


def check_trajectory(traj: Trajectory, limits: JointLimits, dt: float) -> TrajectoryStats:
    """Sample ``traj`` every ``dt`` [s] and measure it against ``limits`` (PlanningError when a
    sample leaves the position limits)."""
    ts = np.arange(0.0, traj.duration + dt, dt)
    q, qd, qdd = traj.sample_many(ts)
    limits.check_position(q, "trajectory")
    step = float(np.abs(np.diff(q, axis=0)).max()) if len(q) > 1 else 0.0
    return TrajectoryStats(
        duration=traj.duration,
        velocity_ratio=float((np.abs(qd) / limits.v_max).max()),
        acceleration_ratio=float((np.abs(qdd) / limits.a_max).max()),
        max_step=step,
    )


def test_limits_from_robot() -> None:
    m = MotionConfig()
    assert np.allclose(LIMITS.a_max, m.accel_scale * LIMITS.v_max)
    assert np.allclose(LIMITS.j_max, m.jerk_scale * LIMITS.a_max)
    grip = JointLimits.from_robot(load_robot(), m, grip=True)
    assert np.allclose(grip.j_max, m.grip_jerk_scale * LIMITS.a_max)
    assert (m.jerk_scale, m.grip_jerk_scale) == (24.0, 12.0)


def test_ptp_respects_limits_and_arrives_together() -> None:
    rng = np.random.default_rng(5)
    margin = 0.1
    for _ in range(50):
        q0 = rng.uniform(LIMITS.lower + margin, LIMITS.upper - margin)
        q1 = rng.uniform(LIMITS.lower + margin, LIMITS.upper - margin)
        traj = plan_ptp(q0, q1, LIMITS)
        stats = check_trajectory(traj, LIMITS, DT)
        assert stats.velocity_ratio <= 1.0 + 1e-6
        assert stats.acceleration_ratio <= 1.0 + 1e-6
        q_end, qd_end, qdd_end = traj.sample(traj.duration)
        assert np.allclose(q_end, q1) and np.allclose(qd_end, 0) and np.allclose(qdd_end, 0)
        # phase synchronisation: every joint's progress is the same fraction at all times
        ts = np.linspace(0, traj.duration, 25)
        q, _, _ = traj.sample_many(ts)
        moving = np.abs(q1 - q0) > 1e-3
        frac = (q[:, moving] - q0[moving]) / (q1 - q0)[moving]
        assert np.abs(frac - frac[:, :1]).max() < 1e-6


def test_ptp_outside_limits_raises() -> None:
    q = np.zeros(6)
    bad = q.copy()
    bad[1] = np.radians(100.0)  # joint_2 upper limit is 85 deg
    with pytest.raises(PlanningError, match=r"joint_2 reaches 100\.0 deg"):
        plan_ptp(q, bad, LIMITS)


def test_sample_clamps_outside_the_time_range() -> None:
    q0, q1 = np.zeros(6), np.full(6, 0.3)
    traj = plan_ptp(q0, q1, LIMITS)
    assert np.allclose(traj.sample(-1.0)[0], q0)
    assert np.allclose(traj.sample(traj.duration + 1.0)[0], q1)
    ts = np.linspace(0, traj.duration, 11)
    many = traj.sample_many(ts)
    for k, t in enumerate(ts):
        one = traj.sample(float(t))
        for a, b in zip(one, many, strict=True):
            assert np.allclose(a, b[k])


def test_chained_segments_are_continuous() -> None:
    qa, qb, qc = np.zeros(6), np.full(6, 0.4), np.array([0.8, 0.1, -0.2, 1.0, -0.5, 2.0])
    first, second = plan_ptp(qa, qb, LIMITS), plan_ptp(qb, qc, LIMITS)
    end, start = first.sample(first.duration), second.sample(0.0)
    for a, b in zip(end, start, strict=True):
        assert np.allclose(a, b, atol=1e-9)


def _line(p0: np.ndarray, p1: np.ndarray, yaw: float = 0.0):  # type: ignore[no-untyped-def]
    T0, T1 = np.eye(4), np.eye(4)
    R = np.array([[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1]])
    T0[:3, :3] = T1[:3, :3] = R
    T0[:3, 3], T1[:3, 3] = p0, p1
    q0 = kin.nearest(T0, np.zeros(6))
    return T0, T1, q0


@pytest.mark.parametrize(
    ("p0", "p1", "yaw"),
    [
        ((1.9, 0.0, 1.6), (2.4, 0.0, 1.6), 0.0),
        ((1.6, -0.6, 0.9), (2.1, -0.8, 0.95), -0.35),
        ((2.3, 0.5, 2.4), (2.3, 0.5, 2.44), 0.2),
    ],
)
def test_cartesian_line_is_straight_and_within_limits(p0, p1, yaw) -> None:  # type: ignore[no-untyped-def]
    p0, p1 = np.array(p0), np.array(p1)
    T0, T1, q0 = _line(p0, p1, yaw)
    traj = plan_cartesian_line(T0, T1, q0, kin.nearest, LIMITS, speed=1.0, step=0.005)
    stats = check_trajectory(traj, LIMITS, DT)
    assert stats.velocity_ratio <= 1.0 and stats.acceleration_ratio <= 1.0 + 1e-6
    assert stats.max_step < 0.02
    ts = np.arange(0, traj.duration + DT, DT)
    q, qd, _ = traj.sample_many(ts)
    T = kin.forward(q)
    u = (p1 - p0) / np.linalg.norm(p1 - p0)
    rel = T[:, :3, 3] - p0
    off_line = np.linalg.norm(rel - np.outer(rel @ u, u), axis=1)
    assert off_line.max() < 1e-4  # 0.1 mm
    assert np.abs(T[:, :3, :3] - T0[:3, :3]).max() < 1e-4
    assert np.allclose(T[-1], T1, atol=1e-9)
    assert np.allclose(qd[0], 0) and np.allclose(qd[-1], 0)
    # the gripper's speed along the line never exceeds the requested speed
    speed = np.linalg.norm(np.diff(T[:, :3, 3], axis=0), axis=1) / DT
    assert speed.max() <= 1.0 + 1e-3


def test_line_through_a_joint_jump_raises() -> None:
    # A line through the wrist singularity with a roll flips q4/q6 by ~pi between samples.
    q = np.array([0.0, 0.2, -0.2, 0.0, 0.3, 0.0])
    T0 = kin.forward(q)
    T1 = kin.forward(np.array([0.0, 0.2, -0.2, 0.0, -0.3, 0.0]))
    T1[:3, :3] = T1[:3, :3] @ np.diag([1.0, -1.0, -1.0])  # roll by pi
    with pytest.raises(PlanningError):
        plan_cartesian_line(T0, T1, q, kin.nearest, LIMITS, speed=0.5, step=0.05)
