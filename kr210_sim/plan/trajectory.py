"""Time-parametrised joint trajectories: ruckig point-to-point moves and straight-line moves.

* :func:`plan_ptp`: a joint-space move from rest to rest, jerk-limited and phase-synchronised by
  ruckig (all joints start and arrive together, on proportional profiles where possible).
* :func:`plan_cartesian_line`: the gripper travels a straight line. The line is sampled densely
  (``step`` m), every sample solved by closed-form IK (``ik(T, q_prev)``, so the branch never
  changes and no joint jumps a full turn), the joint path q(s) interpolated by a C1 cubic
  Hermite spline in the arc length s, and s(t) time-parametrised by a one-DOF ruckig profile
  whose velocity, acceleration and jerk are scaled down until every joint's velocity and
  acceleration stay within its limits. The gripper thus follows the line exactly (up to the IK
  samples' spacing), not a joint-space blend of waypoints.

Ruckig ignores position limits, so every plan is checked against them here. Ruckig's waypoint
input (a cloud service in the community build) is never used: multi-point motions are chained
rest-to-rest segments.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import ruckig

from kr210_sim.cell.spec import MotionConfig
from kr210_sim.errors import PlanningError
from kr210_sim.robot.description import RobotDescription
from kr210_sim.robot.kinematics import LIMIT_SLACK

FloatArray = npt.NDArray[np.float64]
#: An IK function ``ik(T_base_gripper, q_ref) -> q`` (e.g.
#: :func:`kr210_sim.robot.kinematics.nearest`).
IkFunction = Callable[[FloatArray, FloatArray], FloatArray]
#: Largest joint change between consecutive line samples before we call it a jump [rad].
MAX_SAMPLE_JUMP = 0.2


@dataclass(frozen=True, slots=True)
class JointLimits:
    """Kinematic limits of the arm joints, each shape (6,).

    Attributes:
        lower: Lower position limits [rad].
        upper: Upper position limits [rad].
        v_max: Velocity limits [rad/s].
        a_max: Acceleration limits [rad/s^2].
        j_max: Jerk limits [rad/s^3].
    """

    lower: FloatArray
    upper: FloatArray
    v_max: FloatArray
    a_max: FloatArray
    j_max: FloatArray

    def __post_init__(self) -> None:
        for name in ("v_max", "a_max", "j_max"):
            v = getattr(self, name)
            if np.any(~np.isfinite(v)) or np.any(v <= 0):
                raise PlanningError(f"{name} must be positive and finite, got {v}")
        if np.any(self.lower >= self.upper):
            raise PlanningError("every lower position limit must be below its upper limit")

    @classmethod
    def from_robot(
        cls, robot: RobotDescription, motion: MotionConfig, grip: bool = False
    ) -> JointLimits:
        """URDF position and velocity limits; acceleration and jerk from ``motion``'s scales
        (``grip``: the jerk of the moves into, with and out of the grip,
        ``motion.grip_jerk_scale``)."""
        a = motion.accel_scale * robot.qd_max
        jerk = motion.grip_jerk_scale if grip else motion.jerk_scale
        return cls(robot.q_lower.copy(), robot.q_upper.copy(), robot.qd_max.copy(), a, jerk * a)

    def check_position(self, q: FloatArray, what: str) -> None:
        """Raise PlanningError when ``q`` [rad] (shape (..., 6)) leaves the position limits."""
        below = q < self.lower - LIMIT_SLACK
        above = q > self.upper + LIMIT_SLACK
        if np.any(below | above):
            j = int(np.argwhere(below | above)[0][-1])
            v = float(
                np.asarray(q).reshape(-1, 6)[:, j].min()
                if below.any()
                else np.asarray(q).reshape(-1, 6)[:, j].max()
            )
            raise PlanningError(
                f"{what}: joint_{j + 1} reaches {math.degrees(v):.1f} deg, outside its limits "
                f"[{math.degrees(self.lower[j]):.0f}, {math.degrees(self.upper[j]):.0f}] deg"
            )


class Trajectory(ABC):
    """A joint trajectory starting at time 0 and ending at :attr:`duration`, at rest at both ends.

    Subclasses implement :meth:`sample`; times outside [0, duration] give the end states.
    """

    duration: float

    @abstractmethod
    def sample(self, t: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Joint position [rad], velocity [rad/s] and acceleration [rad/s^2] at time ``t`` [s]."""

    def sample_many(self, ts: npt.ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
        """:meth:`sample` at many times: arrays of shape (n, 6)."""
        out = [self.sample(float(t)) for t in np.asarray(ts, dtype=np.float64)]
        if not out:
            empty = np.zeros((0, 6))
            return empty, empty, empty
        q, qd, qdd = zip(*out, strict=True)
        return np.array(q), np.array(qd), np.array(qdd)

    @property
    def q_start(self) -> FloatArray:
        """Joint state at time 0 [rad]."""
        return self.sample(0.0)[0]

    @property
    def q_end(self) -> FloatArray:
        """Joint state at the end [rad]."""
        return self.sample(self.duration)[0]


class PtpTrajectory(Trajectory):
    """A ruckig joint-space profile (see :func:`plan_ptp`)."""

    def __init__(self, profile: ruckig.Trajectory, q_start: FloatArray, q_goal: FloatArray) -> None:
        self._profile = profile
        self.duration = float(profile.duration)
        self._start = q_start.copy()
        self._goal = q_goal.copy()
        self._zero = np.zeros(6)

    @property
    def profile(self) -> ruckig.Trajectory:
        """The ruckig profile."""
        return self._profile

    def sample(self, t: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        if t <= 0.0:
            return self._start.copy(), self._zero.copy(), self._zero.copy()
        if t >= self.duration:
            return self._goal.copy(), self._zero.copy(), self._zero.copy()
        q, qd, qdd = self._profile.at_time(t)[:3]
        return np.array(q), np.array(qd), np.array(qdd)

    def sample_many(self, ts: npt.ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
        t = np.asarray(ts, dtype=np.float64)
        out = np.empty((3, len(t), 6))
        at = self._profile.at_time
        inside = (t > 0.0) & (t < self.duration)
        for i in np.flatnonzero(inside):
            p, v, a = at(float(t[i]))[:3]
            out[0, i], out[1, i], out[2, i] = p, v, a
        out[:, ~inside] = 0.0
        out[0, t <= 0.0] = self._start
        out[0, t >= self.duration] = self._goal
        return out[0], out[1], out[2]


def ruckig_profile(
    q0: FloatArray,
    v0: FloatArray,
    q1: FloatArray,
    v1: FloatArray,
    limits: JointLimits,
    synchronization: ruckig.Synchronization,
    what: str,
) -> ruckig.Trajectory:
    """ruckig's jerk-limited profile from state (``q0`` [rad], ``v0`` [rad/s]) to (``q1``, ``v1``),
    at rest in acceleration at both ends, within ``limits``' velocity, acceleration and jerk.

    Args:
        synchronization: How the joints are synchronised (``Phase`` for straight PTP moves,
            ``Time`` for segments through waypoints).
        what: The profile's name in messages (e.g. ``"PTP profile"``).

    Raises:
        PlanningError: When ruckig finds no profile, or the profile leaves the position limits
            anywhere (ruckig itself ignores them).
    """
    inp = ruckig.InputParameter(6)
    inp.current_position, inp.current_velocity = q0.tolist(), v0.tolist()
    inp.current_acceleration = [0.0] * 6
    inp.target_position, inp.target_velocity = q1.tolist(), v1.tolist()
    inp.target_acceleration = [0.0] * 6
    inp.max_velocity = limits.v_max.tolist()
    inp.max_acceleration = limits.a_max.tolist()
    inp.max_jerk = limits.j_max.tolist()
    inp.synchronization = synchronization
    profile = ruckig.Trajectory(6)
    result = ruckig.Ruckig(6).calculate(inp, profile)
    if result not in (ruckig.Result.Working, ruckig.Result.Finished):
        raise PlanningError(f"ruckig found no {what} ({result})")
    for j, ext in enumerate(profile.position_extrema):
        if ext.min < limits.lower[j] - LIMIT_SLACK or ext.max > limits.upper[j] + LIMIT_SLACK:
            raise PlanningError(f"{what} of joint_{j + 1} overshoots its position limits")
    return profile


def plan_ptp(q_start: npt.ArrayLike, q_goal: npt.ArrayLike, limits: JointLimits) -> PtpTrajectory:
    """A phase-synchronised, jerk-limited joint move from rest at ``q_start`` to rest at ``q_goal``.

    Args:
        q_start: Start joint state [rad], shape (6,).
        q_goal: Goal joint state [rad], shape (6,).
        limits: Joint limits.

    Raises:
        PlanningError: When either end or any point of the profile leaves the position limits,
            or ruckig finds no profile.
    """
    qs = np.asarray(q_start, dtype=np.float64).reshape(6)
    qg = np.asarray(q_goal, dtype=np.float64).reshape(6)
    if not (np.all(np.isfinite(qs)) and np.all(np.isfinite(qg))):
        raise PlanningError("PTP start or goal contains NaN or inf")
    limits.check_position(qs, "PTP start")
    limits.check_position(qg, "PTP goal")
    zero = np.zeros(6)
    profile = ruckig_profile(
        qs, zero, qg, zero, limits, ruckig.Synchronization.Phase, "PTP profile"
    )
    return PtpTrajectory(profile, qs, qg)


def _rotvec(R: FloatArray) -> FloatArray:
    """Rotation vector (axis * angle [rad]) of a rotation matrix."""
    cos = max(-1.0, min(1.0, (np.trace(R) - 1.0) / 2.0))
    angle = math.acos(cos)
    if angle < 1e-12:
        return np.zeros(3)
    v = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if math.pi - angle < 1e-6:  # near pi: axis from the symmetric part
        axis = np.sqrt(np.maximum((np.diag(R) + 1.0) / 2.0, 0.0))
        axis *= np.where(v >= 0, 1.0, -1.0)
        return axis / np.linalg.norm(axis) * angle
    return v / (2.0 * math.sin(angle)) * angle


def _rotation(rotvec: FloatArray) -> FloatArray:
    """Rotation matrix of a rotation vector (Rodrigues)."""
    angle = float(np.linalg.norm(rotvec))
    if angle < 1e-15:
        return np.eye(3)
    k = rotvec / angle
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(angle) * K + (1.0 - math.cos(angle)) * (K @ K)


def _hermite(
    x: Any, p0: FloatArray, p1: FloatArray, m0: FloatArray, m1: FloatArray, h: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Cubic Hermite segment at local parameter ``x`` in [0, 1] (a float or an (n, 1) array):
    value, first and second derivative with respect to arc length (segment length ``h``)."""
    x2, x3 = x * x, x * x * x
    q = (2 * x3 - 3 * x2 + 1) * p0 + (x3 - 2 * x2 + x) * m0 + (-2 * x3 + 3 * x2) * p1
    q = q + (x3 - x2) * m1
    dq = (
        (6 * x2 - 6 * x) * p0
        + (3 * x2 - 4 * x + 1) * m0
        + (-6 * x2 + 6 * x) * p1
        + (3 * x2 - 2 * x) * m1
    ) / h
    ddq = ((12 * x - 6) * p0 + (6 * x - 4) * m0 + (-12 * x + 6) * p1 + (6 * x - 2) * m1) / (h * h)
    return q, dq, ddq


class LineTrajectory(Trajectory):
    """A straight-line Cartesian move: q(s) on a cubic Hermite spline, s(t) from ruckig.

    Attributes:
        bound: Lower bound of the duration [s]: the line from rest to rest at the Cartesian
            speed and at every joint's velocity and acceleration limit, no jerk limit.
    """

    def __init__(
        self,
        q_knots: FloatArray,
        length: float,
        profile: ruckig.Trajectory | None,
        T_start: FloatArray,
        T_goal: FloatArray,
        bound: float = 0.0,
    ) -> None:
        self.bound = bound
        self.q_knots = q_knots
        self.length = length
        self._n = len(q_knots) - 1
        self._ds = length / self._n if self._n else 1.0
        # Catmull-Rom style tangents dq/ds at the knots (one-sided at the ends).
        tangents = np.gradient(q_knots, self._ds, axis=0) if self._n else np.zeros_like(q_knots)
        self._m = tangents
        self._profile = profile
        self.duration = float(profile.duration) if profile is not None else 0.0
        self.T_start = T_start
        self.T_goal = T_goal

    def path(self, s: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        """q(s) [rad], dq/ds [rad/m] and d2q/ds2 [rad/m^2] at arc length ``s`` [m]."""
        if self._n == 0:
            z = np.zeros(6)
            return self.q_knots[0].copy(), z, z
        u = min(max(s / self._ds, 0.0), float(self._n))
        i = min(int(u), self._n - 1)
        x = u - i
        h = self._ds
        p0, p1 = self.q_knots[i], self.q_knots[i + 1]
        m0, m1 = self._m[i] * h, self._m[i + 1] * h
        return _hermite(x, p0, p1, m0, m1, h)

    def path_many(self, s: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """:meth:`path` at many arc lengths ``s`` [m]: arrays of shape (n, 6)."""
        if self._n == 0:
            z = np.zeros((len(s), 6))
            return np.broadcast_to(self.q_knots[0], z.shape).copy(), z, z.copy()
        h = self._ds
        u = np.clip(s / h, 0.0, float(self._n))
        i = np.minimum(u.astype(int), self._n - 1)
        x = (u - i)[:, None]
        p0, p1 = self.q_knots[i], self.q_knots[i + 1]
        m0, m1 = self._m[i] * h, self._m[i + 1] * h
        return _hermite(x, p0, p1, m0, m1, h)

    def sample_many(self, ts: npt.ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
        t = np.asarray(ts, dtype=np.float64)
        prof = np.zeros((3, len(t)))
        if self._profile is not None:
            at = self._profile.at_time
            for k in np.flatnonzero((t > 0.0) & (t < self.duration)):
                (prof[0, k],), (prof[1, k],), (prof[2, k],) = at(float(t[k]))[:3]
            prof[0, t >= self.duration] = self.length
        s, sd, sdd = prof
        q, dq, ddq = self.path_many(s)
        return q, dq * sd[:, None], ddq * (sd * sd)[:, None] + dq * sdd[:, None]

    def sample(self, t: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        if self._profile is None or t >= self.duration:
            z = np.zeros(6)
            return self.q_knots[-1].copy(), z, z.copy()
        if t <= 0.0:
            z = np.zeros(6)
            return self.q_knots[0].copy(), z, z.copy()
        (s,), (sd,), (sdd,) = self._profile.at_time(t)[:3]
        q, dq, ddq = self.path(s)
        return q, dq * sd, ddq * sd * sd + dq * sdd


def line_poses(T_start: npt.ArrayLike, T_goal: npt.ArrayLike, step: float) -> list[FloatArray]:
    """The poses (4x4) :func:`plan_cartesian_line` asks its IK for, in order: the line from
    ``T_start`` to ``T_goal`` sampled every ``step`` [m] (rotation counted as 0.25 m per rad),
    ``T_start`` itself left out; none for a line of no length. A batch-taking IK is asked for
    them at once (:meth:`~kr210_sim.sandbox.ik_guard.CheckedIk.prefetch`)."""
    Ts = np.asarray(T_start, dtype=np.float64)
    Tg = np.asarray(T_goal, dtype=np.float64)
    dp = Tg[:3, 3] - Ts[:3, 3]
    length = float(np.linalg.norm(dp))
    rv = _rotvec(Ts[:3, :3].T @ Tg[:3, :3])
    angle = float(np.linalg.norm(rv))
    if length < 1e-9 and angle < 1e-9:
        return []
    n = max(1, math.ceil(max(length, 0.25 * angle) / step))
    poses = []
    for i in range(1, n + 1):
        u = i / n
        T = np.eye(4)
        T[:3, :3] = Ts[:3, :3] @ _rotation(rv * u)
        T[:3, 3] = Ts[:3, 3] + u * dp
        poses.append(T)
    return poses


def plan_cartesian_line(
    T_start: npt.ArrayLike,
    T_goal: npt.ArrayLike,
    q_start: npt.ArrayLike,
    ik: IkFunction,
    limits: JointLimits,
    speed: float,
    step: float = 0.005,
) -> LineTrajectory:
    """A rest-to-rest move along the straight line from ``T_start`` to ``T_goal``.

    Args:
        T_start: gripper_link pose at the start (4x4); must be the pose of ``q_start``.
        T_goal: gripper_link pose at the end (4x4).
        q_start: Joint state at the start [rad].
        ik: ``ik(T, q_ref) -> q``: the solution nearest ``q_ref``.
        limits: Joint limits.
        speed: Largest Cartesian speed along the line [m/s].
        step: Spacing of the IK samples along the line [m].

    Raises:
        UnreachablePoseError: From ``ik`` when a sample is out of reach.
        PlanningError: When a sample leaves the position limits or a joint would jump.
    """
    Ts = np.asarray(T_start, dtype=np.float64)
    Tg = np.asarray(T_goal, dtype=np.float64)
    q0 = np.asarray(q_start, dtype=np.float64).reshape(6)
    if speed <= 0 or step <= 0:
        raise PlanningError(f"speed and step must be positive, got {speed}, {step}")
    length = float(np.linalg.norm(Tg[:3, 3] - Ts[:3, 3]))
    angle = float(np.linalg.norm(_rotvec(Ts[:3, :3].T @ Tg[:3, :3])))
    poses = line_poses(Ts, Tg, step)  # rotation counts as 0.25 m per rad in the sample count
    if not poses:
        return LineTrajectory(q0[None].copy(), 0.0, None, Ts, Tg)
    n = len(poses)
    knots = np.empty((n + 1, 6))
    knots[0] = q0
    q_prev = q0
    for i, T in enumerate(poses, start=1):
        q = ik(T, q_prev)
        if np.max(np.abs(q - q_prev)) > MAX_SAMPLE_JUMP:
            raise PlanningError(
                f"straight line {Ts[:3, 3].round(3).tolist()} -> {Tg[:3, 3].round(3).tolist()}: "
                f"a joint jumps {np.max(np.abs(q - q_prev)):.2f} rad between samples "
                "(a singularity or a branch change on the way)"
            )
        knots[i] = q
        q_prev = q
    limits.check_position(knots, "straight line")
    path_len = length if length > 1e-9 else 0.25 * angle
    traj = LineTrajectory(knots, path_len, None, Ts, Tg)
    # Scale the path speed so that every joint stays within its velocity and acceleration.
    dq = np.abs(traj._m).max(axis=0) + 1e-12  # [rad/m]
    d2 = np.abs(np.diff(traj._m, axis=0) / traj._ds).max(axis=0) if n > 1 else np.zeros(6)
    v = min(speed if length > 1e-9 else speed * 4.0, float(np.min(0.98 * limits.v_max / dq)))
    a_path = float(np.min((0.9 * limits.a_max - d2 * v * v) / dq))
    if a_path <= 0:
        v = float(np.sqrt(np.min(0.45 * limits.a_max / (d2 + 1e-12))))
        a_path = float(np.min((0.9 * limits.a_max - d2 * v * v) / dq))
    j_path = float(np.min(0.9 * limits.j_max / dq))
    inp = ruckig.InputParameter(1)
    inp.current_position = [0.0]
    inp.target_position = [path_len]
    inp.max_velocity = [v]
    inp.max_acceleration = [a_path]
    inp.max_jerk = [j_path]
    profile = ruckig.Trajectory(1)
    result = ruckig.Ruckig(1).calculate(inp, profile)
    if result not in (ruckig.Result.Working, ruckig.Result.Finished):
        raise PlanningError(f"ruckig found no path profile ({result})")
    v_bound = min(speed if length > 1e-9 else speed * 4.0, float(np.min(limits.v_max / dq)))
    a_bound = float(np.min(limits.a_max / dq))
    if path_len < v_bound * v_bound / a_bound:
        bound = 2.0 * math.sqrt(path_len / a_bound)
    else:
        bound = path_len / v_bound + v_bound / a_bound
    return LineTrajectory(knots, path_len, profile, Ts, Tg, bound)


class ChainTrajectory(Trajectory):
    """Trajectories run one after the other (each at rest at its ends): a move through via
    points.

    Args:
        segments: The pieces, each starting where the one before ends.
    """

    def __init__(self, segments: list[Trajectory]) -> None:
        if not segments:
            raise PlanningError("a chain needs at least one segment")
        self.segments = segments
        self.starts = np.cumsum([0.0] + [s.duration for s in segments[:-1]])
        self.duration = float(self.starts[-1] + segments[-1].duration)

    def sample(self, t: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        i = max(int(np.searchsorted(self.starts, t, side="right")) - 1, 0)
        return self.segments[i].sample(t - float(self.starts[i]))

    def sample_many(self, ts: npt.ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
        t = np.asarray(ts, dtype=np.float64)
        idx = np.clip(np.searchsorted(self.starts, t, side="right") - 1, 0, len(self.segments) - 1)
        q, qd, qdd = np.zeros((len(t), 6)), np.zeros((len(t), 6)), np.zeros((len(t), 6))
        for i, seg in enumerate(self.segments):
            sel = idx == i
            if sel.any():
                q[sel], qd[sel], qdd[sel] = seg.sample_many(t[sel] - self.starts[i])
        return q, qd, qdd
