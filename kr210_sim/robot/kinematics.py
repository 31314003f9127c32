"""Closed-form forward and inverse kinematics of the KR210 (numpy only, no MuJoCo).

A :class:`Kinematics` is built from a robot description and takes its geometry from the
description's URDF joint origins (:attr:`~kr210_sim.robot.description.RobotDescription.geometry`),
never typed in twice; :func:`forward`, :func:`inverse` and :func:`nearest` are those of the
committed URDF. In the URDF frames (every joint origin has rpy = 0)::

    T_base_gripper = Tz(d0) Rz(q1) T(a1, 0, h1) Ry(q2) Tz(a2) Ry(q3) T(a3x, 0, a3z) Rx(q4)
                     Tx(d4b) Ry(q5) Tx(d5) Rx(q6) Tx(dg)

Axes 4, 5 and 6 meet at the wrist centre (the link_5 origin), ``d5 + dg`` = 0.303 m behind
gripper_link along its x axis: inverse kinematics splits into the wrist-centre position (q1, q2,
q3 in closed form: shoulder front/back x elbow up/down) and the wrist orientation (q4, q5, q6:
two wrist flips), up to 8 solutions.

Conventions:

* Angles in [rad], lengths in [m]; poses are 4x4 homogeneous transforms ``T_base_gripper`` of
  the URDF ``gripper_link`` frame in the ``base_link`` frame.
* ``inverse`` returns each branch with joints 1, 4 and 6 wrapped to (-pi, pi] when that is inside
  the limits, otherwise shifted by 2 pi into them; branches that break a limit are dropped.
* At the wrist singularity (``|sin q5| < 1e-9``) only q4 + q6 (or q4 - q6) is defined: ``inverse``
  sets q4 = 0, ``nearest`` keeps q4 at the reference's value.
* ``nearest`` measures distance in time: sum of ((q - q_ref) / v_max)^2 over the joints, and
  picks, for joints 1, 4 and 6, the 2 pi twin inside the limits closest to the reference.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
import numpy.typing as npt

from kr210_sim.errors import UnreachablePoseError
from kr210_sim.robot.description import ARM_JOINTS, Geometry, RobotDescription, load_robot
from kr210_sim.robot.ik_scalar import (
    LIMIT_SLACK,
    TWO_PI,
    WRIST_SINGULAR,
    best_twin,
    inverse_one,
    nearest_one,
)
from kr210_sim.robot.poses import CHUNK, check_pose, check_q, thread_pool

__all__ = [
    "CHUNK",
    "LIMIT_SLACK",
    "TWO_PI",
    "WRIST_SINGULAR",
    "Kinematics",
    "committed",
    "forward",
    "inverse",
    "nearest",
]

FloatArray = npt.NDArray[np.float64]


# --------------------------------------------------------------------------- forward
def _forward(q: npt.ArrayLike, g: Geometry) -> FloatArray:
    """:meth:`Kinematics.forward` with the geometry ``g``."""
    qa = check_q(q)
    if qa.ndim == 1:
        return _forward_scalar(qa.tolist(), g)
    single = False
    qb = qa.reshape(-1, 6)
    c = np.cos(qb)
    s = np.sin(qb)
    c1, c4, c5, c6 = c[:, 0], c[:, 3], c[:, 4], c[:, 5]
    s1, s4, s5, s6 = s[:, 0], s[:, 3], s[:, 4], s[:, 5]
    q23 = qb[:, 1] + qb[:, 2]
    c23, s23 = np.cos(q23), np.sin(q23)
    s2, c2 = s[:, 1], c[:, 1]
    # R3_6 = Rx(q4) Ry(q5) Rx(q6)
    r36 = np.empty((len(qb), 3, 3))
    r36[:, 0, 0] = c5
    r36[:, 0, 1] = s5 * s6
    r36[:, 0, 2] = s5 * c6
    r36[:, 1, 0] = s4 * s5
    r36[:, 1, 1] = c4 * c6 - s4 * c5 * s6
    r36[:, 1, 2] = -c4 * s6 - s4 * c5 * c6
    r36[:, 2, 0] = -c4 * s5
    r36[:, 2, 1] = s4 * c6 + c4 * c5 * s6
    r36[:, 2, 2] = -s4 * s6 + c4 * c5 * c6
    # R0_3 = Rz(q1) Ry(q2 + q3)
    r03 = np.empty((len(qb), 3, 3))
    r03[:, 0, 0] = c1 * c23
    r03[:, 0, 1] = -s1
    r03[:, 0, 2] = c1 * s23
    r03[:, 1, 0] = s1 * c23
    r03[:, 1, 1] = c1
    r03[:, 1, 2] = s1 * s23
    r03[:, 2, 0] = -s23
    r03[:, 2, 1] = 0.0
    r03[:, 2, 2] = c23
    R = r03 @ r36
    radial = g.a1 + g.a2 * s2 + g.a3x * c23 + g.a3z * s23
    z = g.d0 + g.h1 + g.a2 * c2 - g.a3x * s23 + g.a3z * c23
    T = np.zeros((len(qb), 4, 4))
    T[:, :3, :3] = R
    T[:, 0, 3] = radial * c1 + g.dg * R[:, 0, 0]
    T[:, 1, 3] = radial * s1 + g.dg * R[:, 1, 0]
    T[:, 2, 3] = z + g.dg * R[:, 2, 0]
    T[:, 3, 3] = 1.0
    return T[0] if single else T


def _forward_scalar(q: list[float], g: Geometry) -> FloatArray:
    """:func:`forward` for one joint state, in pure ``math`` (the same formulas)."""
    q1, q2, q3, q4, q5, q6 = q
    c1, s1 = math.cos(q1), math.sin(q1)
    c4, s4 = math.cos(q4), math.sin(q4)
    c5, s5 = math.cos(q5), math.sin(q5)
    c6, s6 = math.cos(q6), math.sin(q6)
    c23, s23 = math.cos(q2 + q3), math.sin(q2 + q3)
    # R3_6 = Rx(q4) Ry(q5) Rx(q6)
    a00, a01, a02 = c5, s5 * s6, s5 * c6
    a10, a11, a12 = s4 * s5, c4 * c6 - s4 * c5 * s6, -c4 * s6 - s4 * c5 * c6
    a20, a21, a22 = -c4 * s5, s4 * c6 + c4 * c5 * s6, -s4 * s6 + c4 * c5 * c6
    # R0_3 = Rz(q1) Ry(q23): rows (c1 c23, -s1, c1 s23), (s1 c23, c1, s1 s23), (-s23, 0, c23)
    b00, b01, b02 = c1 * c23, -s1, c1 * s23
    b10, b11, b12 = s1 * c23, c1, s1 * s23
    r00 = b00 * a00 + b01 * a10 + b02 * a20
    r01 = b00 * a01 + b01 * a11 + b02 * a21
    r02 = b00 * a02 + b01 * a12 + b02 * a22
    r10 = b10 * a00 + b11 * a10 + b12 * a20
    r11 = b10 * a01 + b11 * a11 + b12 * a21
    r12 = b10 * a02 + b11 * a12 + b12 * a22
    r20 = -s23 * a00 + c23 * a20
    r21 = -s23 * a01 + c23 * a21
    r22 = -s23 * a02 + c23 * a22
    radial = g.a1 + g.a2 * math.sin(q2) + g.a3x * c23 + g.a3z * s23
    z = g.d0 + g.h1 + g.a2 * math.cos(q2) - g.a3x * s23 + g.a3z * c23
    return np.array(
        [
            [r00, r01, r02, radial * c1 + g.dg * r00],
            [r10, r11, r12, radial * s1 + g.dg * r10],
            [r20, r21, r22, z + g.dg * r20],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


# --------------------------------------------------------------------------- inverse (batch)
def _wrap(a: FloatArray) -> FloatArray:
    """Angles wrapped to (-pi, pi]."""
    w = np.remainder(a + math.pi, TWO_PI) - math.pi
    return np.where(w <= -math.pi, w + TWO_PI, w)


def _inverse_batch(T: FloatArray, g: Geometry) -> FloatArray:
    """All 8 branches inside the limits for poses (N, 4, 4) -> (N, 8, 6), NaN elsewhere.

    Works in chunks of :data:`CHUNK` poses (cache-sized temporaries), spread over a small thread
    pool for large batches (numpy releases the GIL in its loops).
    """
    n = T.shape[0]
    if n <= CHUNK:
        return _fit_limits(_branches(T, g), g)
    out = np.empty((n, 8, 6))

    def work(i: int) -> None:
        out[i : i + CHUNK] = _fit_limits(_branches(T[i : i + CHUNK], g), g)

    list(thread_pool().map(work, range(0, n, CHUNK)))
    return out


def _branches(T: FloatArray, g: Geometry) -> FloatArray:
    """The 8 geometric branches for poses (N, 4, 4) -> (N, 8, 6), NaN where one does not exist.

    No joint limit is applied; angles are as atan2 gives them. Branch b = 4 * shoulder +
    2 * elbow + flip (0 = front / elbow +acos / flip +), the order of the single-pose path.
    """
    n = T.shape[0]
    R = T[:, :3, :3]
    w = T[:, :3, 3] - g.dg * R[:, :, 0]
    L, phi, a2 = g.forearm, g.forearm_angle, g.a2
    shoulder = np.array([1.0, -1.0])
    base_q1 = np.arctan2(w[:, 1], w[:, 0])
    q1 = base_q1[:, None] + np.array([0.0, math.pi])  # (N, 2)
    rho = np.hypot(w[:, 0], w[:, 1])
    zz = (w[:, 2] - g.d0 - g.h1)[:, None]  # (N, 1)
    x = shoulder * rho[:, None] - g.a1  # (N, 2)
    cos_d = (x * x + zz * zz - a2 * a2 - L * L) / (2.0 * a2 * L)
    exists = np.abs(cos_d) <= 1.0 + 1e-12
    np.clip(cos_d, -1.0, 1.0, out=cos_d)
    acos = np.arccos(cos_d)
    # elbow +/-: delta = +/-acos, so q2 = pi/2 - atan2(zz, x) +/- atan2(L sin|delta|, a2 + L cos)
    A = np.arctan2(zz, x)
    B = np.arctan2(L * np.sqrt(1.0 - cos_d * cos_d), a2 + L * cos_d)
    q2 = np.stack([math.pi / 2.0 - A + B, math.pi / 2.0 - A - B], axis=2).reshape(n, 4)
    q3 = np.stack([-acos, acos], axis=2).reshape(n, 4) - (phi + math.pi / 2.0)
    q1_4 = np.repeat(q1, 2, axis=1)
    c1b, s1b = np.cos(base_q1)[:, None], np.sin(base_q1)[:, None]
    sign = np.array([1.0, 1.0, -1.0, -1.0])  # cos/sin(q1 + pi) = -cos/sin(q1)
    c1, s1 = c1b * sign, s1b * sign
    q23 = q2 + q3
    c23, s23 = np.cos(q23), np.sin(q23)
    # R3_6 = Ry(q23)^T Rz(q1)^T R: only the entries the wrist angles need.
    r = [[R[:, i, j][:, None] for j in range(3)] for i in range(3)]
    t0 = [c1 * r[0][j] + s1 * r[1][j] for j in range(3)]
    m10 = -s1 * r[0][0] + c1 * r[1][0]
    m11 = -s1 * r[0][1] + c1 * r[1][1]
    m00 = t0[0] * c23 - r[2][0] * s23
    m01 = t0[1] * c23 - r[2][1] * s23
    m02 = t0[2] * c23 - r[2][2] * s23
    m20 = t0[0] * s23 + r[2][0] * c23
    m21 = t0[1] * s23 + r[2][1] * c23
    s5 = np.hypot(m10, m20)
    singular = s5 < WRIST_SINGULAR
    flip = np.array([1.0, -1.0])[None, None, :]
    q5 = np.arctan2(flip * s5[..., None], m00[..., None])  # (N, 4, 2)
    q4 = np.arctan2(flip * m10[..., None], -flip * m20[..., None])
    q6 = np.arctan2(flip * m01[..., None], flip * m02[..., None])
    if singular.any():
        pos = m00 > 0
        q4 = np.where(singular[..., None], 0.0, q4)
        q5 = np.where(singular[..., None], np.where(pos, 0.0, math.pi)[..., None], q5)
        q6s = np.arctan2(np.where(pos, 1.0, -1.0) * m21, m11)
        q6 = np.where(singular[..., None], q6s[..., None], q6)
    out = np.empty((n, 4, 2, 6))
    out[..., 0] = q1_4[..., None]
    out[..., 1] = q2[..., None]
    out[..., 2] = q3[..., None]
    out[..., 3] = q4
    out[..., 4] = q5
    out[..., 5] = q6
    out[~np.repeat(exists, 2, axis=1)] = np.nan
    return out.reshape(n, 8, 6)


def _fit_limits(sol: FloatArray, g: Geometry) -> FloatArray:
    """Wrap every joint to (-pi, pi], shift by 2 pi into the limits where needed (joints 1, 3,
    4 and 6 have ranges past +-pi), and NaN the rows that still break a limit (in place).

    Every angle :func:`_branches` produces lies in (-2 pi, 3 pi), so one conditional shift
    wraps it (cheaper than ``np.remainder`` on millions of angles).
    """
    lo = g.lower - LIMIT_SLACK
    hi = g.upper + LIMIT_SLACK
    bad = np.zeros(sol.shape[:-1], dtype=bool)
    with np.errstate(invalid="ignore"):
        for j in range(6):
            v = sol[..., j]
            if j < 3:  # q4, q5, q6 come from atan2, already in (-pi, pi]
                v[v > math.pi] -= TWO_PI
                v[v <= -math.pi] += TWO_PI
            if lo[j] < -math.pi:
                v[v > hi[j]] -= TWO_PI
            if hi[j] > math.pi:
                v[v < lo[j]] += TWO_PI
            bad |= (v < lo[j]) | (v > hi[j])
    sol[bad] = np.nan
    return sol


def _inverse(T: npt.ArrayLike, g: Geometry) -> FloatArray:
    """:meth:`Kinematics.inverse` with the geometry ``g`` (one pose: the scalar path)."""
    if type(T) is np.ndarray and T.shape == (4, 4):
        return inverse_one(T, g)
    Ta = check_pose(T)
    if Ta.ndim == 2:
        return inverse_one(Ta, g)
    return _inverse_batch(Ta, g)


def _nearest(T: npt.ArrayLike, q_ref: npt.ArrayLike, g: Geometry) -> FloatArray:
    """:meth:`Kinematics.nearest` with the geometry ``g``."""
    if type(T) is not np.ndarray or T.shape != (4, 4):
        T = check_pose(T)
        if T.ndim != 2:
            raise ValueError(f"nearest takes one pose (4, 4), got {T.shape}")
    best = nearest_one(T, q_ref, g)
    if not best:
        raise UnreachablePoseError(_why_unreachable(np.asarray(T, dtype=np.float64), g))
    return np.array(best)


def _why_unreachable(T: FloatArray, g: Geometry) -> str:
    """A sentence on why a pose has no solution inside the limits."""
    R = T[:3, :3]
    w = T[:3, 3] - g.dg * R[:, 0]
    rho = math.hypot(w[0], w[1])
    zz = w[2] - g.d0 - g.h1
    best_gap, too_close = math.inf, False
    for shoulder in (1.0, -1.0):
        d = math.hypot(shoulder * rho - g.a1, zz)
        outer, inner = d - g.reach, abs(g.a2 - g.forearm) - d
        if max(outer, inner) < best_gap:
            best_gap, too_close = max(outer, inner), inner > outer
    if best_gap > 0:
        # mm below 1 cm: "0.000 m beyond" said nothing for a pose just out of reach
        gap = f"{1000 * best_gap:.3g} mm" if best_gap < 0.01 else f"{best_gap:.3f} m"
        where = np.round(w, 3).tolist()
        if too_close:
            return (
                f"out of reach: the wrist centre {where} is {gap} closer to joint_2 than the "
                f"folded arm reaches ({abs(g.a2 - g.forearm):.3f} m)"
            )
        return (
            f"out of reach: the wrist centre {where} is {gap} beyond the arm's "
            f"{g.reach:.3f} m reach from joint_2"
        )
    # For each joint, the smallest excess over its limits among the branches that need it.
    excess: dict[int, float] = {}
    for row in _branches(T[None], g)[0]:
        if np.isnan(row[0]):
            continue
        for jnt in range(6):
            v = best_twin(math.remainder(float(row[jnt]), TWO_PI), 0.0, g.lower[jnt], g.upper[jnt])
            over = max(g.lower[jnt] - v, v - g.upper[jnt])
            if over > LIMIT_SLACK:
                excess[jnt] = min(excess.get(jnt, math.inf), over)
    parts = [
        f"{ARM_JOINTS[jnt]} by >= {math.degrees(e):.1f} deg" for jnt, e in sorted(excess.items())
    ]
    return "every solution breaks a joint limit: " + ", ".join(parts)


# --------------------------------------------------------------------------- the API
class Kinematics:
    """The closed-form kinematics of one robot description.

    Built from the description a caller passes (as mink's ``Configuration`` carries its model):
    a description with other joint origins or limits has its own forward and inverse kinematics.
    The package's planner, runner, scoring and checks each use the :class:`Kinematics` of the
    robot they were given.

    Args:
        robot: The robot description (its :attr:`~RobotDescription.geometry` is used).

    Attributes:
        robot: The description.
        geometry: Its closed-form constants.
    """

    __slots__ = ("geometry", "robot")

    def __init__(self, robot: RobotDescription) -> None:
        self.robot = robot
        self.geometry = robot.geometry

    def forward(self, q: npt.ArrayLike) -> FloatArray:
        """Pose of gripper_link in the base_link frame.

        Args:
            q: Joint positions [rad], shape (6,) or (N, 6).

        Returns:
            ``T_base_gripper``, shape (4, 4) or (N, 4, 4).

        Raises:
            ValueError: On a wrong shape, NaN or inf.
        """
        return _forward(q, self.geometry)

    def inverse(self, T: npt.ArrayLike) -> FloatArray:
        """Every inverse-kinematics solution inside the joint limits.

        Args:
            T: gripper_link pose(s) in the base frame, shape (4, 4) or (N, 4, 4).

        Returns:
            For one pose: (k, 6) [rad], k = 0 ... 8 distinct solutions in a fixed branch order
            (shoulder front/back x elbow x wrist flip); k = 0 when the pose is unreachable.
            For N poses: (N, 8, 6) with NaN rows for branches that do not exist or break a limit.

        Raises:
            ValueError: On a wrong shape, NaN/inf, or a non-orthonormal rotation.
        """
        return _inverse(T, self.geometry)

    def nearest(self, T: npt.ArrayLike, q_ref: npt.ArrayLike) -> FloatArray:
        """The solution for ``T`` closest to ``q_ref`` (no full-turn jumps).

        Among all branches and all 2 pi twins of joints 1, 4 and 6 inside the limits, returns
        the one that minimises sum(((q - q_ref) / v_max)^2), i.e. roughly the fastest to reach.
        At the wrist singularity, q4 stays at ``q_ref[3]``.

        Args:
            T: gripper_link pose in the base frame, shape (4, 4).
            q_ref: Reference joint state [rad], shape (6,).

        Returns:
            Joint positions [rad], shape (6,).

        Raises:
            ValueError: On invalid input.
            UnreachablePoseError: When no solution lies inside the limits; the message says by
                how much the pose is out of reach, or which joint limit excludes it.
        """
        return _nearest(T, q_ref, self.geometry)


@lru_cache(maxsize=1)
def committed() -> Kinematics:
    """The kinematics of the committed URDF (for scripts, tests and the ``--ik`` SPEC below)."""
    return Kinematics(load_robot())


def forward(q: npt.ArrayLike) -> FloatArray:
    """:meth:`Kinematics.forward` of the committed KR210."""
    return _forward(q, committed().geometry)


def inverse(T: npt.ArrayLike) -> FloatArray:
    """:meth:`Kinematics.inverse` of the committed KR210."""
    return _inverse(T, committed().geometry)


def nearest(T: npt.ArrayLike, q_ref: npt.ArrayLike) -> FloatArray:
    """:meth:`Kinematics.nearest` of the committed KR210: the user-IK contract
    ``solve(T, q_ref)``, so ``--ik kr210_sim.robot.kinematics:nearest`` plans with our closed
    form through the user-IK path."""
    return _nearest(T, q_ref, committed().geometry)
