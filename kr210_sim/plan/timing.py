"""Timing a planned joint path through its waypoints without stopping at each one, and the
lower bounds a move's duration is measured against.

A path from the sampling planner is a list of joint states joined by straight segments. It is
timed as ruckig state-to-state segments chained at the waypoints with *non-zero* velocities
there (jerk-limited, time-synchronised; ruckig's own waypoint input is a cloud service and is
never used). The velocity at an interior waypoint is, joint by joint, the slower of the average
speeds of the two segments it joins when they move that joint the same way, else zero. Ruckig's
path between two waypoints bends away from the straight segment, so the caller checks the timed
samples again (``accept``); when they collide the waypoint velocities are halved, down to
rest-to-rest segments, whose phase-synchronised profiles follow the straight segments exactly.

Bounds: a rest-to-rest move cannot be faster than its slowest joint alone at the velocity and
acceleration limits (:func:`rest_to_rest_bound`); a timed path cannot be faster than the
time-optimal parametrisation of the same geometric path under those limits (:func:`path_bound`,
:mod:`kr210_sim.plan.topp`).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable

import numpy as np
import numpy.typing as npt
import ruckig

from kr210_sim.errors import PlanningError
from kr210_sim.plan.topp import time_optimal_duration
from kr210_sim.plan.trajectory import JointLimits, Trajectory, plan_ptp, ruckig_profile

FloatArray = npt.NDArray[np.float64]

#: Times the waypoint velocities are halved before the path is timed rest to rest.
BLEND_TRIES = 3
#: Share of the velocity limit a waypoint velocity may use.
WAYPOINT_SPEED = 0.9
#: Sample step of the limit check [s].
LIMIT_DT = 0.002
#: Slack on the velocity and acceleration limits in the check (ruckig's own rounding).
RATE_SLACK = 1e-6


def joint_min_time(distance: FloatArray, v_max: FloatArray, a_max: FloatArray) -> FloatArray:
    """Shortest rest-to-rest time of each joint alone over ``distance`` [rad] with velocity
    and acceleration limits (no jerk limit) [s]."""
    d = np.abs(np.asarray(distance, dtype=np.float64))
    triangle = d < v_max * v_max / a_max
    return np.where(triangle, 2.0 * np.sqrt(d / a_max), d / v_max + v_max / a_max)


def rest_to_rest_bound(q_start: npt.ArrayLike, q_goal: npt.ArrayLike, limits: JointLimits) -> float:
    """Lower bound of a rest-to-rest joint move's duration: its slowest joint alone [s]."""
    d = np.asarray(q_goal, dtype=np.float64) - np.asarray(q_start, dtype=np.float64)
    return float(joint_min_time(d, limits.v_max, limits.a_max).max(initial=0.0))


def path_bound(q: npt.ArrayLike, limits: JointLimits) -> float:
    """Time-optimal duration of the geometric path through the joint states ``q`` (n, 6)
    [rad] at the velocity and acceleration limits, from rest to rest
    (:func:`~kr210_sim.plan.topp.time_optimal_duration`) [s]."""
    return time_optimal_duration(q, limits.v_max, limits.a_max)


class BlendedTrajectory(Trajectory):
    """Ruckig segments chained at waypoints, each starting in the state the previous ends in.

    Args:
        profiles: The segments' ruckig trajectories.
        q_start: The first segment's start [rad].
        q_goal: The last segment's end [rad].
    """

    def __init__(self, profiles: list[ruckig.Trajectory], q_start: FloatArray, q_goal: FloatArray):
        self.profiles = profiles
        durations = [float(p.duration) for p in profiles]
        self.starts = np.concatenate([[0.0], np.cumsum(durations)[:-1]])
        self.duration = float(sum(durations))
        self._start = np.asarray(q_start, dtype=np.float64).copy()
        self._goal = np.asarray(q_goal, dtype=np.float64).copy()

    def sample(self, t: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        z = np.zeros(6)
        if t <= 0.0:
            return self._start.copy(), z, z.copy()
        if t >= self.duration:
            return self._goal.copy(), z, z.copy()
        i = max(int(np.searchsorted(self.starts, t, side="right")) - 1, 0)
        p = self.profiles[i]
        q, qd, qdd = p.at_time(min(t - float(self.starts[i]), float(p.duration)))[:3]
        return np.array(q), np.array(qd), np.array(qdd)

    def sample_many(self, ts: npt.ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
        t = np.asarray(ts, dtype=np.float64)
        out = np.zeros((3, len(t), 6))
        inside = (t > 0.0) & (t < self.duration)
        seg = np.maximum(np.searchsorted(self.starts, t, side="right") - 1, 0)
        for i, p in enumerate(self.profiles):
            at, start, end = p.at_time, float(self.starts[i]), float(p.duration)
            for k in np.flatnonzero(inside & (seg == i)):
                out[0, k], out[1, k], out[2, k] = at(min(float(t[k]) - start, end))[:3]
        out[0, t <= 0.0] = self._start
        out[0, t >= self.duration] = self._goal
        return out[0], out[1], out[2]


def waypoint_velocities(way: FloatArray, limits: JointLimits, scale: float) -> FloatArray:
    """Joint velocities at the waypoints ``way`` (k, 6) [rad/s] (see the module doc), times
    ``scale``; zero at both ends."""
    d = np.diff(way, axis=0)  # (k - 1, 6)
    durations = np.array([rest_to_rest_bound(np.zeros(6), x, limits) for x in d])
    avg = d / np.maximum(durations, 1e-9)[:, None]
    v = np.zeros_like(way)
    same = np.sign(d[:-1]) * np.sign(d[1:]) > 0
    slower = np.minimum(np.abs(avg[:-1]), np.abs(avg[1:])) * np.sign(d[1:])
    v[1:-1] = np.where(same, slower, 0.0) * scale
    return np.clip(v, -WAYPOINT_SPEED * limits.v_max, WAYPOINT_SPEED * limits.v_max)


def _segment(
    q0: FloatArray, v0: FloatArray, q1: FloatArray, v1: FloatArray, limits: JointLimits
) -> ruckig.Trajectory:
    return ruckig_profile(q0, v0, q1, v1, limits, ruckig.Synchronization.Time, "segment profile")


def blend(way: FloatArray, limits: JointLimits, scale: float = 1.0) -> Trajectory:
    """The path through the waypoints ``way`` (k, 6) [rad] timed with waypoint velocities at
    ``scale`` (0: rest to rest, phase-synchronised, along the straight segments).

    Raises:
        PlanningError: When a segment leaves the position limits or ruckig finds no profile.
    """
    way = np.asarray(way, dtype=np.float64)
    if scale <= 0.0 or len(way) == 2:
        segments = [plan_ptp(a, b, limits) for a, b in itertools.pairwise(way)]
        if len(segments) == 1:
            return segments[0]
        return BlendedTrajectory([s.profile for s in segments], way[0], way[-1])
    v = waypoint_velocities(way, limits, scale)
    profiles = [_segment(way[i], v[i], way[i + 1], v[i + 1], limits) for i in range(len(way) - 1)]
    return BlendedTrajectory(profiles, way[0], way[-1])


def check_limits(traj: Trajectory, limits: JointLimits) -> tuple[float, float]:
    """Check ``traj``'s samples every :data:`LIMIT_DT` against the position, velocity and
    acceleration limits.

    Returns:
        The largest |qd| / v_max and |qdd| / a_max over joints and samples.

    Raises:
        PlanningError: When a sample breaks a limit.
    """
    ts = np.append(np.arange(0.0, traj.duration, LIMIT_DT), traj.duration)
    q, qd, qdd = traj.sample_many(ts)
    limits.check_position(q, "timed path")
    v = float((np.abs(qd) / limits.v_max).max())
    a = float((np.abs(qdd) / limits.a_max).max())
    if v > 1.0 + RATE_SLACK or a > 1.0 + RATE_SLACK:
        raise PlanningError(
            f"timed path: {v:.3f} of the velocity limit, {a:.3f} of the acceleration limit"
        )
    return v, a


def time_path(
    way: npt.ArrayLike,
    limits: JointLimits,
    accept: Callable[[Trajectory], bool],
) -> tuple[Trajectory, float]:
    """Time the path through ``way`` (k, 6) [rad] as fast as ``accept`` allows.

    Args:
        way: Waypoints [rad], the first and last at rest.
        limits: Joint limits.
        accept: Checks a timed candidate (its samples against the cell).

    Returns:
        The trajectory and the waypoint-velocity scale it was timed with (0: rest to rest).

    Raises:
        PlanningError: When even the rest-to-rest timing is not accepted.
    """
    w = np.asarray(way, dtype=np.float64)
    scale = 1.0
    for _ in range(BLEND_TRIES):
        try:
            traj = blend(w, limits, scale)
        except PlanningError:
            traj = None
        if traj is not None and accept(traj):
            return traj, scale
        scale /= 2.0
    traj = blend(w, limits, 0.0)
    if not accept(traj):
        raise PlanningError("the planned path, timed rest to rest, is not accepted")
    return traj, 0.0
