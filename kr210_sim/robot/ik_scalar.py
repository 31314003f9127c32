"""The single-pose path of the closed-form IK: one pose in pure ``math`` on Python floats.

:func:`inverse_one` and :func:`nearest_one` are :meth:`Kinematics.inverse` and
:meth:`Kinematics.nearest` for one (4, 4) pose: the formulas of the batch path
(``kinematics._branches`` and ``_fit_limits``) for one pose, without numpy's cost per call
(about 1 us for each small array an expression makes). What makes them fast:

* the pose is read with one ``tolist`` and checked in one expression
  (:func:`~kr210_sim.robot.poses.check_pose_flat`);
* every constant the formulas need is worked out once per geometry (:func:`constants`), with
  flags that spare the wrap of a joint whose range holds all of [-pi, pi] (joints 4 and 6 of
  the KR210) and of one that no 2 pi shift can bring into its range (joints 2 and 5);
* the answer is packed into its array with :mod:`struct`;
* ``nearest`` is searched branch and bound (:func:`nearest_solution`): about one wrist is worked
  out a pose instead of four when the reference is near a solution.

:func:`solutions` and :func:`nearest_solution` each keep the whole computation in one function:
split into helpers for the arm and the wrist, the calls and their arguments cost a fifth more.
The arithmetic is the path's they replace, operation by operation (the same floats on random,
singular, limit and unreachable poses); tests compare both with the batch path.

The same two functions are compiled too (``_ik_native.c``, built by ``pip install`` where a C
compiler is at hand): :func:`inverse_one` and :func:`nearest_one` are the compiled ones when
the extension was built and imports, :func:`inverse_one_py` and :func:`nearest_one_py`
otherwise, or when the environment sets ``KR210_SIM_PURE_IK=1``. :data:`NATIVE` says which.
Both paths give the same floats (tests compare them pose by pose).

Angles in [rad], lengths in [m].
"""

from __future__ import annotations

import math
import os
import struct
from collections.abc import Callable
from math import acos, atan2, cos, hypot, isfinite, sin
from typing import Any

import numpy as np
import numpy.typing as npt

from kr210_sim.robot.description import Geometry
from kr210_sim.robot.poses import check_pose_flat

FloatArray = npt.NDArray[np.float64]
TWO_PI = 2.0 * math.pi
PI = math.pi
NEG_PI = -math.pi
HALF_PI = math.pi / 2.0
#: |sin q5| below which the wrist counts as straight (singular).
WRIST_SINGULAR = 1e-9
#: Slack on the joint limits when checking solutions [rad].
LIMIT_SLACK = 1e-9
#: |sin q5| below which ``nearest`` keeps q4 at the reference's value.
NEAREST_STRAIGHT = 1e-7
#: A twin nearer the reference than this [rad] is the nearest of all (the others are > pi away).
_NEAR = math.pi - 1e-6
_NEG_NEAR = -_NEAR
_NEG_STRAIGHT = -NEAREST_STRAIGHT
_F64 = np.dtype(np.float64)
#: Packers of k solutions (k = 1 ... 8) into an array's buffer.
_PACK = [struct.Struct(f"{6 * k}d").pack_into for k in range(9)]
_CACHE: dict[int, tuple[Geometry, tuple[Any, ...]]] = {}


def wrap_into(v: float, lo: float, hi: float) -> float | None:
    """``v`` wrapped to (-pi, pi] and shifted by 2 pi into [lo, hi]; None if impossible."""
    if -math.pi < v <= math.pi and lo - LIMIT_SLACK <= v <= hi + LIMIT_SLACK:
        return v
    v = math.remainder(v, TWO_PI)
    if v < lo - LIMIT_SLACK:
        v += TWO_PI
    elif v > hi + LIMIT_SLACK:
        v -= TWO_PI
    if lo - LIMIT_SLACK <= v <= hi + LIMIT_SLACK:
        return v
    return None


def best_twin(value: float, ref: float, lo: float, hi: float) -> float:
    """The 2 pi twin of ``value`` inside [lo, hi] closest to ``ref`` (the first of k0 - 1, k0,
    k0 + 1 turns among equals, k0 the nearest in turns); ``value`` if none is inside."""
    lo -= LIMIT_SLACK
    hi += LIMIT_SLACK
    best, best_d = value, math.inf
    k0 = round((ref - value) / TWO_PI)
    v = value + (k0 - 1) * TWO_PI
    if lo <= v <= hi:
        best, best_d = v, abs(v - ref)
    v = value + k0 * TWO_PI
    if lo <= v <= hi and abs(v - ref) < best_d:
        best, best_d = v, abs(v - ref)
    v = value + (k0 + 1) * TWO_PI
    if lo <= v <= hi and abs(v - ref) < best_d:
        best = v
    return best


def constants(g: Geometry) -> tuple[Any, ...]:
    """The floats the single-pose formulas need, computed once per geometry.

    Returns:
        (dg, d0, h1, a1, a2, L, phi, a2 * a2, L * L, 2 a2 L, lower, upper, lower - slack,
        upper + slack, flags, inv_v2), ``inv_v2`` = 1 / v_max^2. ``flags``: for joints 1, 4,
        5 and 6, the range holds all of [-pi, pi] (an atan2 there needs no wrap); for joints 2,
        3 and then 5, the range lies inside (-pi, pi) (an angle in (-pi, pi] outside it cannot
        be shifted in); last, both of joints 4 and 6 hold [-pi, pi] and joint 5 lies inside
        (-pi, pi) (the KR210: the wrist flips need no wrap and no shift).
    """
    hit = _CACHE.get(id(g))
    if hit is not None and hit[0] is g:
        return hit[1]
    L, a2 = g.forearm, g.a2
    lo, hi = tuple(g.lower_list), tuple(g.upper_list)
    lo_s = tuple(v - LIMIT_SLACK for v in lo)
    hi_s = tuple(v + LIMIT_SLACK for v in hi)
    wide = [lo_s[j] <= -math.pi and hi_s[j] >= math.pi for j in range(6)]
    inner = [lo_s[j] > -math.pi + 1e-6 and hi_s[j] < math.pi - 1e-6 for j in range(6)]
    quick = wide[3] and wide[5] and inner[4]
    flags = (wide[0], inner[1], inner[2], wide[3], wide[4], wide[5], inner[4], quick)
    c = (g.dg, g.d0, g.h1, g.a1, a2, L, g.forearm_angle, a2 * a2, L * L, 2.0 * a2 * L,
         lo, hi, lo_s, hi_s, flags, tuple(g.inv_v2_list))  # fmt: skip
    if len(_CACHE) > 64:  # descriptions made in a loop: keep the cache small
        _CACHE.clear()
    _CACHE[id(g)] = (g, c)
    return c


def solutions(flat: list[float], c: tuple[Any, ...]) -> list[float]:
    """Every branch of one pose inside the limits: 6 k floats, the k solutions in the batch
    path's order (shoulder front/back x elbow +/- x wrist flip +/-).

    Args:
        flat: The pose's 16 entries, row by row, checked (``check_pose_flat``).
        c: :func:`constants` of the geometry.
    """
    r00, r01, r02, px, r10, r11, r12, py, r20, r21, r22, pz, _, _, _, _ = flat
    dg, d0, h1, a1, a2, L, phi, a2sq, Lsq, den, lo, hi, lo_s, hi_s, flags, _ = c
    lo1, lo2, lo3, lo4, lo5, lo6 = lo_s
    hi1, hi2, hi3, hi4, hi5, hi6 = hi_s
    wide1, inner2, inner3, wide4, wide5, wide6, _, quick = flags
    wx, wy, wz = px - dg * r00, py - dg * r10, pz - dg * r20
    base_q1 = atan2(wy, wx)
    rho = hypot(wx, wy)
    zz = wz - d0 - h1
    out: list[float] = []
    for back in (False, True):
        if back:
            q1 = base_q1 + PI
            x = -rho - a1
        else:
            q1 = base_q1
            x = rho - a1
        cos_d = (x * x + zz * zz - a2sq - Lsq) / den
        if cos_d > 1.0:
            if cos_d > 1.0 + 1e-12:
                continue
            cos_d = 1.0
        elif cos_d < -1.0:
            if cos_d < -1.0 - 1e-12:
                continue
            cos_d = -1.0
        q1w = q1
        if not (NEG_PI < q1 <= PI and (wide1 or lo1 <= q1 <= hi1)):
            w1w = wrap_into(q1, lo[0], hi[0])
            if w1w is None:
                continue
            q1w = w1w
        rows = False
        ac = acos(cos_d)
        A = atan2(zz, x)
        B = atan2(L * sin(ac), a2 + L * cos(ac))
        for elbow in (1.0, -1.0) if -1.0 < cos_d < 1.0 else (1.0,):
            q2 = HALF_PI - (A - elbow * B)
            q2w = q2
            if not (lo2 <= q2 <= hi2 and (inner2 or NEG_PI < q2 <= PI)):
                if inner2 and NEG_PI < q2 <= PI:  # no 2 pi shift brings it inside
                    continue
                w2w = wrap_into(q2, lo[1], hi[1])
                if w2w is None:
                    continue
                q2w = w2w
            q3 = -(elbow * ac) - phi - HALF_PI
            q3w = q3
            if not (lo3 <= q3 <= hi3 and (inner3 or NEG_PI < q3 <= PI)):
                if inner3 and NEG_PI < q3 <= PI:
                    continue
                w3w = wrap_into(q3, lo[2], hi[2])
                if w3w is None:
                    continue
                q3w = w3w
            if not rows:  # rows of Rz(q1)^T R, once per shoulder
                rows = True
                c1, s1 = cos(q1), sin(q1)
                t00, t01, t02 = c1 * r00 + s1 * r10, c1 * r01 + s1 * r11, c1 * r02 + s1 * r12
                m10, m11 = -s1 * r00 + c1 * r10, -s1 * r01 + c1 * r11
            # R3_6 = Ry(q2 + q3)^T Rz(q1)^T R: the entries the wrist angles need
            q23 = q2 + q3
            c23, s23 = cos(q23), sin(q23)
            m00 = t00 * c23 - r20 * s23
            m20 = t00 * s23 + r20 * c23
            s5 = hypot(m10, m20)
            if s5 < WRIST_SINGULAR:  # the flips coincide: one solution, with q4 = 0
                m21 = t01 * s23 + r21 * c23
                v5, v6 = (0.0, atan2(m21, m11)) if m00 > 0 else (PI, atan2(-m21, m11))
                if not (wide5 or (NEG_PI < v5 and lo5 <= v5 <= hi5)):
                    v5w = wrap_into(v5, lo[4], hi[4])
                    if v5w is None:
                        continue
                    v5 = v5w
                if not (wide6 or (NEG_PI < v6 and lo6 <= v6 <= hi6)):
                    v6w = wrap_into(v6, lo[5], hi[5])
                    if v6w is None:
                        continue
                    v6 = v6w
                v4 = 0.0
                if not (wide4 or lo4 <= 0.0 <= hi4):
                    v4w = wrap_into(0.0, lo[3], hi[3])
                    if v4w is None:
                        continue
                    v4 = v4w
                out += (q1w, q2w, q3w, v4, v5, v6)
                continue
            m01 = t01 * c23 - r21 * s23
            m02 = t02 * c23 - r22 * s23
            q5 = atan2(s5, m00)
            if quick:  # q4, q6 need no wrap, q5 no shift (the KR210): the flips written out
                if lo5 <= q5 <= hi5:
                    out += (q1w, q2w, q3w, atan2(m10, -m20), q5, atan2(m01, m02))
                if lo5 <= -q5 <= hi5:
                    out += (q1w, q2w, q3w, atan2(-m10, m20), -q5, atan2(-m01, -m02))
                continue
            for flip in (1.0, -1.0):
                v5 = q5 if flip > 0.0 else -q5
                if not (wide5 or (NEG_PI < v5 and lo5 <= v5 <= hi5)):
                    v5w = wrap_into(v5, lo[4], hi[4])
                    if v5w is None:
                        continue
                    v5 = v5w
                if flip > 0.0:
                    v4, v6 = atan2(m10, -m20), atan2(m01, m02)
                else:
                    v4, v6 = atan2(-m10, m20), atan2(-m01, -m02)
                if not (wide4 or (NEG_PI < v4 and lo4 <= v4 <= hi4)):
                    v4w = wrap_into(v4, lo[3], hi[3])
                    if v4w is None:
                        continue
                    v4 = v4w
                if not (wide6 or (NEG_PI < v6 and lo6 <= v6 <= hi6)):
                    v6w = wrap_into(v6, lo[5], hi[5])
                    if v6w is None:
                        continue
                    v6 = v6w
                out += (q1w, q2w, q3w, v4, v5, v6)
    return out


def nearest_solution(flat: list[float], c: tuple[Any, ...], ref: list[float]) -> list[float]:
    """The solution of one pose closest in time to ``ref``: the formulas of :func:`solutions`,
    searched branch and bound.

    Every branch, with joints 1, 4 and 6 at their 2 pi twins inside the limits closest to
    ``ref``, costs sum(((q - ref) / v_max)^2); the least cost wins, the first in branch order
    among equals. Each joint only adds to the cost, so the shoulders are taken cheapest q1
    first, in each the elbows cheapest q1..q3 first, and a shoulder or arm that alone costs more
    than the best solution so far is not worked out further. At |sin q5| < 1e-7, q4 is kept
    at ``ref[3]`` and q6 moved by the same.

    Args:
        flat: The pose's 16 entries, row by row, checked (``check_pose_flat``).
        c: :func:`constants` of the geometry.
        ref: The reference joint state [rad], six floats.

    Returns:
        The six joints [rad]; empty when no solution lies inside the limits.
    """
    r00, r01, r02, px, r10, r11, r12, py, r20, r21, r22, pz, _, _, _, _ = flat
    dg, d0, h1, a1, a2, L, phi, a2sq, Lsq, den, lo, hi, lo_s, hi_s, flags, w = c
    lo1, lo2, lo3, lo4, lo5, lo6 = lo_s
    hi1, hi2, hi3, hi4, hi5, hi6 = hi_s
    wide1, inner2, inner3, wide4, wide5, wide6, inner5, _ = flags
    f1, f2, f3, f4, f5, f6 = ref
    w1, w2, w3, w4, w5, w6 = w
    wx, wy, wz = px - dg * r00, py - dg * r10, pz - dg * r20
    base_q1 = atan2(wy, wx)
    rho = hypot(wx, wy)
    zz = wz - d0 - h1
    # the shoulders: (cost of q1, 0 front / 1 back, q1 as returned, q1 raw)
    shoulders: list[tuple[float, int, float, float]] = []
    for back in (0, 1):
        q1 = base_q1 + PI if back else base_q1
        q1w = q1
        if not (NEG_PI < q1 <= PI and (wide1 or lo1 <= q1 <= hi1)):
            w1w = wrap_into(q1, lo[0], hi[0])
            if w1w is None:
                continue
            q1w = w1w
        # a lower bound of q1's cost: its nearest twin, inside the limits or not (with a margin
        # for the rounding of near ties); the twin inside the limits only if the shoulder is tried
        d = q1w + round((f1 - q1w) / TWO_PI) * TWO_PI - f1
        shoulders.append((d * d * w1 * (1.0 - 1e-9), back, q1w, q1))
    if len(shoulders) == 2 and shoulders[1][0] < shoulders[0][0]:
        shoulders.reverse()
    best: list[float] = []
    best_cost, best_key = math.inf, 8
    for bound1, back, q1w, q1 in shoulders:
        if bound1 > best_cost:
            break
        t1 = q1w + round((f1 - q1w) / TWO_PI) * TWO_PI
        d = t1 - f1
        if not (_NEG_NEAR < d < _NEAR and lo1 <= t1 <= hi1):
            t1 = best_twin(q1w, f1, lo[0], hi[0])
            d = t1 - f1
        cost1 = d * d * w1
        x = -rho - a1 if back else rho - a1
        cos_d = (x * x + zz * zz - a2sq - Lsq) / den
        if cos_d > 1.0:
            if cos_d > 1.0 + 1e-12:
                continue
            cos_d = 1.0
        elif cos_d < -1.0:
            if cos_d < -1.0 - 1e-12:
                continue
            cos_d = -1.0
        ac = acos(cos_d)
        A = atan2(zz, x)
        B = atan2(L * sin(ac), a2 + L * cos(ac))
        # the arms of this shoulder: (cost of q1..q3, 0 elbow + / 1 elbow -, q2, q3, q2 + q3)
        arms: list[tuple[float, bool, float, float, float]] = []
        for elbow in (1.0, -1.0) if -1.0 < cos_d < 1.0 else (1.0,):
            q2 = HALF_PI - (A - elbow * B)
            q2w = q2
            if not (lo2 <= q2 <= hi2 and (inner2 or NEG_PI < q2 <= PI)):
                if inner2 and NEG_PI < q2 <= PI:
                    continue
                w2w = wrap_into(q2, lo[1], hi[1])
                if w2w is None:
                    continue
                q2w = w2w
            q3 = -(elbow * ac) - phi - HALF_PI
            q3w = q3
            if not (lo3 <= q3 <= hi3 and (inner3 or NEG_PI < q3 <= PI)):
                if inner3 and NEG_PI < q3 <= PI:
                    continue
                w3w = wrap_into(q3, lo[2], hi[2])
                if w3w is None:
                    continue
                q3w = w3w
            d = q2w - f2
            cost = cost1 + d * d * w2
            d = q3w - f3
            cost += d * d * w3
            arms.append((cost, elbow < 0.0, q2w, q3w, q2 + q3))
        if len(arms) == 2 and arms[1][0] < arms[0][0]:
            arms.reverse()
        rows = False
        for cost3, lower, q2w, q3w, q23 in arms:
            if cost3 > best_cost:
                break
            if not rows:
                rows = True
                c1, s1 = cos(q1), sin(q1)
                t00, t01, t02 = c1 * r00 + s1 * r10, c1 * r01 + s1 * r11, c1 * r02 + s1 * r12
                m10, m11 = -s1 * r00 + c1 * r10, -s1 * r01 + c1 * r11
            c23, s23 = cos(q23), sin(q23)
            m00 = t00 * c23 - r20 * s23
            m20 = t00 * s23 + r20 * c23
            s5 = hypot(m10, m20)
            singular = s5 < WRIST_SINGULAR
            if singular:
                m21 = t01 * s23 + r21 * c23
            else:
                m01 = t01 * c23 - r21 * s23
                m02 = t02 * c23 - r22 * s23
                q5 = atan2(s5, m00)
            # the flip with q5 on the reference's side first: the other then often costs more
            for flip in (0,) if singular else (1, -1) if f5 >= 0.0 else (-1, 1):
                if flip == 0:  # the flips coincide: q4 = 0
                    v5 = 0.0 if m00 > 0 else PI
                else:
                    v5 = q5 if flip > 0 else -q5
                if not (wide5 or (lo5 <= v5 <= hi5 and (inner5 or NEG_PI < v5))):
                    v5w = wrap_into(v5, lo[4], hi[4])
                    if v5w is None:
                        continue
                    v5 = v5w
                d = v5 - f5
                c5 = d * d * w5
                if cost3 + c5 > best_cost:  # a lower bound of the cost, in floating point too
                    continue
                if flip == 0:
                    v4, v6 = 0.0, (atan2(m21, m11) if m00 > 0 else atan2(-m21, m11))
                elif flip > 0:
                    v4, v6 = atan2(m10, -m20), atan2(m01, m02)
                else:
                    v4, v6 = atan2(-m10, m20), atan2(-m01, -m02)
                if not (wide4 or (NEG_PI < v4 and lo4 <= v4 <= hi4)):
                    v4w = wrap_into(v4, lo[3], hi[3])
                    if v4w is None:
                        continue
                    v4 = v4w
                if not (wide6 or (NEG_PI < v6 and lo6 <= v6 <= hi6)):
                    v6w = wrap_into(v6, lo[5], hi[5])
                    if v6w is None:
                        continue
                    v6 = v6w
                if _NEG_STRAIGHT < sin(v5) < NEAREST_STRAIGHT:  # keep q4, move q6 by the same
                    shift = f4 - v4
                    v4 = f4
                    v6 = v6 - shift if cos(v5) > 0 else v6 + shift
                    if not (lo6 <= v6 <= hi6):
                        v6w = wrap_into(v6, lo[5], hi[5])
                        if v6w is None:
                            continue
                        v6 = v6w
                t = v4 + round((f4 - v4) / TWO_PI) * TWO_PI
                d = t - f4
                if not (_NEG_NEAR < d < _NEAR and lo4 <= t <= hi4):
                    t = best_twin(v4, f4, lo[3], hi[3])
                    d = t - f4
                v4 = t
                cost = cost3 + d * d * w4 + c5
                if cost > best_cost:
                    continue
                t = v6 + round((f6 - v6) / TWO_PI) * TWO_PI
                d = t - f6
                if not (_NEG_NEAR < d < _NEAR and lo6 <= t <= hi6):
                    t = best_twin(v6, f6, lo[5], hi[5])
                    d = t - f6
                v6 = t
                cost += d * d * w6
                if cost <= best_cost:
                    key = 4 * back + 2 * lower + (flip < 0)
                    if cost < best_cost or key < best_key:
                        best_cost, best_key = cost, key
                        best = [t1, q2w, q3w, v4, v5, v6]
    return best


def inverse_one_py(T: Any, g: Geometry) -> FloatArray:
    """:meth:`Kinematics.inverse` of one pose on the pure-Python path: (k, 6) [rad],
    k = 0 ... 8."""
    if type(T) is not np.ndarray or T.dtype is not _F64:
        T = np.asarray(T, dtype=np.float64)
    flat: list[float] = T.ravel().tolist()
    check_pose_flat(flat)
    hit = _CACHE.get(id(g))  # constants(g), without the call
    out = solutions(flat, hit[1] if hit is not None and hit[0] is g else constants(g))
    k = len(out) // 6
    sol = np.empty((k, 6))
    if k:
        _PACK[k](sol.data, 0, *out)
    return sol


def reference(q_ref: Any) -> list[float]:
    """``q_ref`` as six finite floats [rad].

    Raises:
        ValueError: On a wrong shape, NaN or inf.
    """
    if type(q_ref) is not np.ndarray or q_ref.dtype is not _F64:
        q_ref = np.asarray(q_ref, dtype=np.float64)
    if q_ref.shape != (6,):
        raise ValueError(f"q_ref must have shape (6,), got {q_ref.shape}")
    ref: list[float] = q_ref.tolist()
    total = ref[0] + ref[1] + ref[2] + ref[3] + ref[4] + ref[5]
    if total - total != 0.0 and not all(isfinite(v) for v in ref):
        raise ValueError("q_ref contains NaN or inf")
    return ref


def nearest_one_py(T: Any, q_ref: Any, g: Geometry) -> list[float]:
    """:meth:`Kinematics.nearest` of one pose on the pure-Python path: the six joints [rad],
    empty when the pose has no solution inside the limits."""
    if type(T) is not np.ndarray or T.dtype is not _F64:
        T = np.asarray(T, dtype=np.float64)
    flat: list[float] = T.ravel().tolist()
    check_pose_flat(flat)
    if type(q_ref) is np.ndarray and q_ref.dtype is _F64 and q_ref.shape == (6,):
        ref: list[float] = q_ref.tolist()  # reference(q_ref), the check inline
        total = ref[0] + ref[1] + ref[2] + ref[3] + ref[4] + ref[5]
        if total - total != 0.0:
            ref = reference(q_ref)
    else:
        ref = reference(q_ref)
    hit = _CACHE.get(id(g))
    return nearest_solution(flat, hit[1] if hit is not None and hit[0] is g else constants(g), ref)


def _pure_asked() -> bool:
    """Whether the environment asks for the pure-Python path (``KR210_SIM_PURE_IK`` set, not
    0)."""
    return os.environ.get("KR210_SIM_PURE_IK", "") not in ("", "0")


def _load_native() -> Any:
    """The compiled module, set up with this module's functions to fall back on; None when it
    was not built or ``KR210_SIM_PURE_IK=1``."""
    if _pure_asked():
        return None
    try:
        import kr210_sim.robot._ik_native as _ik_native
    except ImportError:
        return None
    _ik_native.setup(inverse_one_py, nearest_one_py, check_pose_flat, constants, np.empty)
    return _ik_native


def which_path() -> str:
    """Which single-pose path is in use, and why, in a few words (``--version`` prints it)."""
    if _NATIVE_MODULE is not None:
        return "compiled (kr210_sim.robot._ik_native)"
    if _pure_asked():
        return "pure Python (KR210_SIM_PURE_IK is set)"
    return "pure Python (the compiled extension was not built: no C compiler at install?)"


_NATIVE_MODULE = _load_native()
#: Whether :func:`inverse_one` and :func:`nearest_one` are the compiled functions.
NATIVE: bool = _NATIVE_MODULE is not None
#: :meth:`Kinematics.inverse` of one pose: (k, 6) [rad], k = 0 ... 8 (compiled when NATIVE).
inverse_one: Callable[[Any, Geometry], FloatArray] = (
    _NATIVE_MODULE.inverse_one if NATIVE else inverse_one_py
)
#: :meth:`Kinematics.nearest` of one pose: the six joints [rad], empty when the pose has no
#: solution inside the limits (compiled when NATIVE).
nearest_one: Callable[[Any, Any, Geometry], list[float]] = (
    _NATIVE_MODULE.nearest_one if NATIVE else nearest_one_py
)
