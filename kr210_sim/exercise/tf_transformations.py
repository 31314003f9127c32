"""``tf.transformations`` as ROS shipped it: homogeneous 4x4 matrices, Euler angles in 24 axis
conventions, and quaternions ordered ``(x, y, z, w)``.

tf carried an early copy of Christoph Gohlke's ``transformations`` module. The ``transformations``
package on PyPI today orders quaternions ``(w, x, y, z)`` and checks shapes differently, so an
IK server run against it computes silently wrong angles. This module is our own implementation
of the functions IK servers call, with tf's semantics:

* quaternions are ``(x, y, z, w)``; ``quaternion_matrix`` normalises its argument, and a
  quaternion of (near) zero length gives the identity;
* ``euler_from_matrix`` reads the top-left 3x3 of what it is given (a 3x3 rotation or a 4x4
  transform), as tf's did; ``quaternion_from_matrix`` reads a 4x4 (tf's used ``M[3, 3]``, so a
  3x3 fails there with numpy's ``IndexError``, as it did under ROS);
* axes are a string (``'sxyz'``: static frame, rotations about x, then y, then z; ``'rzyx'``:
  rotating frame) or a tuple ``(first axis, parity, repetition, frame)``;
* ``_EPS`` (4 machine epsilons) decides when a matrix is at gimbal lock, where the third angle
  is 0.

Sympy matrices and lists are accepted wherever numbers are (converted with ``numpy.asarray``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]

#: Below this a length counts as zero (tf's ``_EPS``).
_EPS = float(np.finfo(float).eps) * 4.0
#: The next axis in the cycle x -> y -> z -> x (index 3 wraps).
_NEXT_AXIS = [1, 2, 0, 1]
#: Axis strings to (first axis, parity, repetition, frame): the static-frame ("s") ones, and
#: each rotating-frame ("r") one, which is the static one with the axes in reverse order.
_STATIC = {
    "xyz": (0, 0, 0),
    "xyx": (0, 0, 1),
    "xzy": (0, 1, 0),
    "xzx": (0, 1, 1),
    "yzx": (1, 0, 0),
    "yzy": (1, 0, 1),
    "yxz": (1, 1, 0),
    "yxy": (1, 1, 1),
    "zxy": (2, 0, 0),
    "zxz": (2, 0, 1),
    "zyx": (2, 1, 0),
    "zyz": (2, 1, 1),
}
_AXES2TUPLE = {f"s{n}": (*t, 0) for n, t in _STATIC.items()}
_AXES2TUPLE |= {f"r{n[::-1]}": (*t, 1) for n, t in _STATIC.items()}
_TUPLE2AXES = {v: k for k, v in _AXES2TUPLE.items()}


def _axes(axes: str | Sequence[int]) -> tuple[int, int, int, int]:
    """``axes`` as (first axis, parity, repetition, frame); ``KeyError`` for an unknown one."""
    if isinstance(axes, str):
        return _AXES2TUPLE[axes.lower()]
    first, parity, repetition, frame = (int(a) for a in axes)
    t = (first, parity, repetition, frame)
    if t not in _TUPLE2AXES:  # as tf: an unknown tuple is a KeyError
        raise KeyError(t)
    return t


def _array(data: Any) -> FloatArray:
    return np.array(np.asarray(data, dtype=object).tolist(), dtype=np.float64)


# -- basics -----------------------------------------------------------------------------------
def identity_matrix() -> FloatArray:
    """The 4x4 identity."""
    return np.identity(4)


def translation_matrix(direction: npt.ArrayLike) -> FloatArray:
    """The 4x4 translation by ``direction[:3]``."""
    M = np.identity(4)
    M[:3, 3] = _array(direction)[:3]
    return M


def translation_from_matrix(matrix: Any) -> FloatArray:
    """The translation of a 4x4 transform."""
    return _array(matrix)[:3, 3].copy()


def vector_norm(data: Any, axis: int | None = None, out: Any = None) -> Any:
    """The Euclidean length of ``data`` (along ``axis``)."""
    data = _array(data)
    if out is None:
        if data.ndim == 1:
            return math.sqrt(float(np.dot(data, data)))
        return np.sqrt(np.sum(data * data, axis=axis))
    np.sqrt(np.sum(data * data, axis=axis), out=out)
    return None


def unit_vector(data: Any, axis: int | None = None, out: Any = None) -> Any:
    """``data`` divided by its length (along ``axis``)."""
    data = _array(data)
    if out is not None:
        out[...] = data
        data = out
    if data.ndim == 1:
        data = data / math.sqrt(float(np.dot(data, data)))
    else:
        length = np.atleast_1d(np.sqrt(np.sum(data * data, axis=axis)))
        if axis is not None:
            length = np.expand_dims(length, axis)
        data = data / length
    if out is not None:
        out[...] = data
        return None
    return data


def random_vector(size: int) -> FloatArray:
    """``size`` numbers drawn uniformly from [0, 1)."""
    return np.random.default_rng().random(size)


def inverse_matrix(matrix: Any) -> FloatArray:
    """The inverse of a square matrix."""
    return np.asarray(np.linalg.inv(_array(matrix)), dtype=np.float64)


def concatenate_matrices(*matrices: Any) -> FloatArray:
    """The product of the 4x4 matrices, left to right (the identity for none)."""
    M = np.identity(4)
    for m in matrices:
        M = M @ _array(m)
    return M


def is_same_transform(matrix0: Any, matrix1: Any) -> bool:
    """Whether two 4x4 matrices are one transform (each divided by its ``[3, 3]``)."""
    m0, m1 = _array(matrix0), _array(matrix1)
    return bool(np.allclose(m0 / m0[3, 3], m1 / m1[3, 3]))


# -- rotations, reflections, scaling ----------------------------------------------------------
def rotation_matrix(angle: float, direction: npt.ArrayLike, point: Any = None) -> FloatArray:
    """The 4x4 rotation by ``angle`` [rad] about the axis ``direction`` through ``point``."""
    s, c = math.sin(angle), math.cos(angle)
    u = unit_vector(_array(direction)[:3])
    R = c * np.identity(3) + (1.0 - c) * np.outer(u, u)
    R += s * np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])
    M = np.identity(4)
    M[:3, :3] = R
    if point is not None:
        p = _array(point)[:3]
        M[:3, 3] = p - R @ p
    return M


def _eigenvector(M: FloatArray, value: float, what: str) -> FloatArray:
    w, V = np.linalg.eig(M)
    i = np.flatnonzero(abs(np.real(w) - value) < 1e-8)
    if not len(i):
        raise ValueError(f"no unit eigenvector corresponding to eigenvalue {value:g} ({what})")
    return np.real(V[:, i[-1]]).squeeze()


def rotation_from_matrix(matrix: Any) -> tuple[float, FloatArray, FloatArray]:
    """``(angle, direction, point)`` of a 4x4 rotation."""
    R = _array(matrix)
    direction = _eigenvector(R[:3, :3].T, 1.0, "direction")
    point = _eigenvector(R, 1.0, "point")
    point = point / point[3]
    cosa = (float(np.trace(R[:3, :3])) - 1.0) / 2.0
    if abs(direction[2]) > 1e-8:
        sina = (R[1, 0] + (cosa - 1.0) * direction[0] * direction[1]) / direction[2]
    elif abs(direction[1]) > 1e-8:
        sina = (R[0, 2] + (cosa - 1.0) * direction[0] * direction[2]) / direction[1]
    else:
        sina = (R[2, 1] + (cosa - 1.0) * direction[1] * direction[2]) / direction[0]
    return math.atan2(sina, cosa), direction, point


def reflection_matrix(point: npt.ArrayLike, normal: npt.ArrayLike) -> FloatArray:
    """The 4x4 mirror in the plane through ``point`` with ``normal``."""
    n = unit_vector(_array(normal)[:3])
    M = np.identity(4)
    M[:3, :3] -= 2.0 * np.outer(n, n)
    M[:3, 3] = (2.0 * float(np.dot(_array(point)[:3], n))) * n
    return M


def reflection_from_matrix(matrix: Any) -> tuple[FloatArray, FloatArray]:
    """``(point, normal)`` of a 4x4 reflection."""
    M = _array(matrix)
    normal = _eigenvector(M[:3, :3], -1.0, "normal")
    point = _eigenvector(M, 1.0, "point")
    return point / point[3], normal


def scale_matrix(factor: float, origin: Any = None, direction: Any = None) -> FloatArray:
    """The 4x4 scaling by ``factor`` about ``origin`` (along ``direction``, when given)."""
    if direction is None:
        M = np.diag([factor, factor, factor, 1.0])
        if origin is not None:
            M[:3, 3] = _array(origin)[:3] * (1.0 - factor)
        return M
    d = unit_vector(_array(direction)[:3])
    M = np.identity(4)
    M[:3, :3] -= (1.0 - factor) * np.outer(d, d)
    if origin is not None:
        M[:3, 3] = ((1.0 - factor) * float(np.dot(_array(origin)[:3], d))) * d
    return M


# -- Euler angles -----------------------------------------------------------------------------
def _order(axes: str | Sequence[int]) -> tuple[int, int, int, int, int, int]:
    first, parity, repetition, frame = _axes(axes)
    i = first
    j = _NEXT_AXIS[i + parity]
    k = _NEXT_AXIS[i - parity + 1]
    return i, j, k, parity, repetition, frame


def euler_matrix(ai: float, aj: float, ak: float, axes: str | Sequence[int] = "sxyz") -> FloatArray:
    """The 4x4 rotation of Euler angles ``ai``, ``aj``, ``ak`` [rad] about ``axes``."""
    i, j, k, parity, repetition, frame = _order(axes)
    if frame:
        ai, ak = ak, ai
    if parity:
        ai, aj, ak = -ai, -aj, -ak
    si, sj, sk = math.sin(ai), math.sin(aj), math.sin(ak)
    ci, cj, ck = math.cos(ai), math.cos(aj), math.cos(ak)
    cc, cs, sc, ss = ci * ck, ci * sk, si * ck, si * sk
    M = np.identity(4)
    if repetition:
        M[i, i], M[i, j], M[i, k] = cj, sj * si, sj * ci
        M[j, i], M[j, j], M[j, k] = sj * sk, -cj * ss + cc, -cj * cs - sc
        M[k, i], M[k, j], M[k, k] = -sj * ck, cj * sc + cs, cj * cc - ss
    else:
        M[i, i], M[i, j], M[i, k] = cj * ck, sj * sc - cs, sj * cc + ss
        M[j, i], M[j, j], M[j, k] = cj * sk, sj * ss + cc, sj * cs - sc
        M[k, i], M[k, j], M[k, k] = -sj, cj * si, cj * ci
    return M


def euler_from_matrix(matrix: Any, axes: str | Sequence[int] = "sxyz") -> tuple[float, ...]:
    """The Euler angles [rad] about ``axes`` of a rotation (the top-left 3x3 of ``matrix``).

    At gimbal lock (the middle rotation's cosine, or sine for repeated axes, below ``_EPS``)
    the third angle is 0.
    """
    i, j, k, parity, repetition, frame = _order(axes)
    M = _array(matrix)[:3, :3]
    if repetition:
        sy = math.hypot(M[i, j], M[i, k])
        if sy > _EPS:
            ax = math.atan2(M[i, j], M[i, k])
            ay = math.atan2(sy, M[i, i])
            az = math.atan2(M[j, i], -M[k, i])
        else:
            ax = math.atan2(-M[j, k], M[j, j])
            ay = math.atan2(sy, M[i, i])
            az = 0.0
    else:
        cy = math.hypot(M[i, i], M[j, i])
        if cy > _EPS:
            ax = math.atan2(M[k, j], M[k, k])
            ay = math.atan2(-M[k, i], cy)
            az = math.atan2(M[j, i], M[i, i])
        else:
            ax = math.atan2(-M[j, k], M[j, j])
            ay = math.atan2(-M[k, i], cy)
            az = 0.0
    if parity:
        ax, ay, az = -ax, -ay, -az
    if frame:
        ax, az = az, ax
    return ax, ay, az


def euler_from_quaternion(
    quaternion: npt.ArrayLike, axes: str | Sequence[int] = "sxyz"
) -> tuple[float, ...]:
    """The Euler angles [rad] about ``axes`` of the quaternion ``(x, y, z, w)``."""
    return euler_from_matrix(quaternion_matrix(quaternion), axes)


def quaternion_from_euler(
    ai: float, aj: float, ak: float, axes: str | Sequence[int] = "sxyz"
) -> FloatArray:
    """The quaternion ``(x, y, z, w)`` of Euler angles ``ai``, ``aj``, ``ak`` [rad] about
    ``axes``."""
    i, j, k, parity, repetition, frame = _order(axes)
    if frame:
        ai, ak = ak, ai
    if parity:
        aj = -aj
    ai, aj, ak = ai / 2.0, aj / 2.0, ak / 2.0
    si, sj, sk = math.sin(ai), math.sin(aj), math.sin(ak)
    ci, cj, ck = math.cos(ai), math.cos(aj), math.cos(ak)
    cc, cs, sc, ss = ci * ck, ci * sk, si * ck, si * sk
    q = np.empty(4)
    if repetition:
        q[i], q[j], q[k] = cj * (cs + sc), sj * (cc + ss), sj * (cs - sc)
        q[3] = cj * (cc - ss)
    else:
        q[i], q[j], q[k] = cj * sc - sj * cs, cj * ss + sj * cc, cj * cs - sj * sc
        q[3] = cj * cc + sj * ss
    if parity:
        q[j] = -q[j]
    return q


# -- quaternions (x, y, z, w) -----------------------------------------------------------------
def quaternion_about_axis(angle: float, axis: npt.ArrayLike) -> FloatArray:
    """The quaternion of a rotation by ``angle`` [rad] about ``axis``."""
    q = np.zeros(4)
    q[:3] = _array(axis)[:3]
    length = float(np.linalg.norm(q[:3]))
    if length > _EPS:
        q[:3] *= math.sin(angle / 2.0) / length
    q[3] = math.cos(angle / 2.0)
    return q


def quaternion_matrix(quaternion: npt.ArrayLike) -> FloatArray:
    """The 4x4 rotation of the quaternion ``(x, y, z, w)`` (normalised first; the identity
    for one of length below ``_EPS``)."""
    q = _array(quaternion)[:4].copy()
    n = float(np.dot(q, q))
    if n < _EPS:
        return np.identity(4)
    q *= math.sqrt(2.0 / n)
    x, y, z, w = q
    M = np.identity(4)
    M[:3, :3] = [
        [1.0 - y * y - z * z, x * y - z * w, x * z + y * w],
        [x * y + z * w, 1.0 - x * x - z * z, y * z - x * w],
        [x * z - y * w, y * z + x * w, 1.0 - x * x - y * y],
    ]
    return M


def quaternion_from_matrix(matrix: Any) -> FloatArray:
    """The quaternion ``(x, y, z, w)`` of a 4x4 rotation (tf's: it reads ``M[3, 3]``)."""
    M = _array(matrix)[:4, :4]
    t = float(np.trace(M))
    scale = M[3, 3]  # IndexError for a 3x3, as tf's
    q = np.empty(4)
    if t > scale:
        q[3] = t
        q[2] = M[1, 0] - M[0, 1]
        q[1] = M[0, 2] - M[2, 0]
        q[0] = M[2, 1] - M[1, 2]
    else:
        i, j, k = 0, 1, 2
        if M[1, 1] > M[0, 0]:
            i, j, k = 1, 2, 0
        if M[2, 2] > M[i, i]:
            i, j, k = 2, 0, 1
        t = M[i, i] - (M[j, j] + M[k, k]) + scale
        q[i] = t
        q[j] = M[i, j] + M[j, i]
        q[k] = M[k, i] + M[i, k]
        q[3] = M[k, j] - M[j, k]
    return q * (0.5 / math.sqrt(t * scale))


def quaternion_multiply(quaternion1: npt.ArrayLike, quaternion0: npt.ArrayLike) -> FloatArray:
    """The product ``quaternion1 * quaternion0`` (rotate by ``quaternion0`` first)."""
    x0, y0, z0, w0 = _array(quaternion0)[:4]
    x1, y1, z1, w1 = _array(quaternion1)[:4]
    return np.array(
        [
            w1 * x0 + x1 * w0 + y1 * z0 - z1 * y0,
            w1 * y0 - x1 * z0 + y1 * w0 + z1 * x0,
            w1 * z0 + x1 * y0 - y1 * x0 + z1 * w0,
            w1 * w0 - x1 * x0 - y1 * y0 - z1 * z0,
        ]
    )


def quaternion_conjugate(quaternion: npt.ArrayLike) -> FloatArray:
    """``(-x, -y, -z, w)``."""
    q = _array(quaternion)[:4].copy()
    q[:3] = -q[:3]
    return q


def quaternion_inverse(quaternion: npt.ArrayLike) -> FloatArray:
    """The inverse: the conjugate over the squared length."""
    q = _array(quaternion)[:4]
    return quaternion_conjugate(q) / float(np.dot(q, q))


def quaternion_slerp(
    quat0: npt.ArrayLike,
    quat1: npt.ArrayLike,
    fraction: float,
    spin: int = 0,
    shortestpath: bool = True,
) -> FloatArray:
    """The spherical interpolation ``fraction`` of the way from ``quat0`` to ``quat1``."""
    q0 = unit_vector(_array(quat0)[:4])
    q1 = unit_vector(_array(quat1)[:4])
    if fraction == 0.0:
        return q0
    if fraction == 1.0:
        return q1
    d = float(np.dot(q0, q1))
    if abs(abs(d) - 1.0) < _EPS:
        return q0
    if shortestpath and d < 0.0:
        d, q1 = -d, -q1
    angle = math.acos(d) + spin * math.pi
    if abs(angle) < _EPS:
        return q0
    s = 1.0 / math.sin(angle)
    return q0 * (math.sin((1.0 - fraction) * angle) * s) + q1 * (math.sin(fraction * angle) * s)


def random_quaternion(rand: npt.ArrayLike | None = None) -> FloatArray:
    """A uniformly random unit quaternion (from three numbers in [0, 1), drawn when None)."""
    r = np.random.default_rng().random(3) if rand is None else _array(rand)
    r1, r2 = math.sqrt(1.0 - r[0]), math.sqrt(r[0])
    t1, t2 = 2.0 * math.pi * r[1], 2.0 * math.pi * r[2]
    return np.array([math.sin(t1) * r1, math.cos(t1) * r1, math.sin(t2) * r2, math.cos(t2) * r2])


def random_rotation_matrix(rand: npt.ArrayLike | None = None) -> FloatArray:
    """A uniformly random 4x4 rotation."""
    return quaternion_matrix(random_quaternion(rand))


# -- whole transforms -------------------------------------------------------------------------
def compose_matrix(
    scale: Any = None,
    shear: Any = None,
    angles: Any = None,
    translate: Any = None,
    perspective: Any = None,
) -> FloatArray:
    """The 4x4 ``perspective * translate * rotate('sxyz' angles) * shear * scale``."""
    M = np.identity(4)
    if perspective is not None:
        P = np.identity(4)
        P[3, :] = _array(perspective)[:4]
        M = M @ P
    if translate is not None:
        M = M @ translation_matrix(translate)
    if angles is not None:
        a = _array(angles)
        M = M @ euler_matrix(a[0], a[1], a[2], "sxyz")
    if shear is not None:
        Z = np.identity(4)
        h = _array(shear)
        Z[1, 2], Z[0, 2], Z[0, 1] = h[2], h[1], h[0]
        M = M @ Z
    if scale is not None:
        M = M @ np.diag([*_array(scale)[:3], 1.0])
    M /= M[3, 3]
    return M


def decompose_matrix(matrix: Any) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, Any]:
    """``(scale, shear, angles, translate, perspective)`` of a 4x4 transform (the inverse of
    :func:`compose_matrix`; ``ValueError`` for a singular one)."""
    M = _array(matrix).T.copy()
    if abs(M[3, 3]) < _EPS:
        raise ValueError("M[3, 3] is zero")
    M /= M[3, 3]
    P = M.copy()
    P[:, 3] = [0.0, 0.0, 0.0, 1.0]
    if not np.linalg.det(P):
        raise ValueError("matrix is singular")
    scale, shear, angles = np.zeros(3), np.zeros(3), np.zeros(3)
    if any(abs(M[:3, 3]) > _EPS):
        perspective = np.linalg.solve(P.T, M[:, 3])
        M[:, 3] = [0.0, 0.0, 0.0, 1.0]
    else:
        perspective = np.array([0.0, 0.0, 0.0, 1.0])
    translate = M[3, :3].copy()
    M[3, :3] = 0.0
    row = M[:3, :3].copy()
    scale[0] = vector_norm(row[0])
    row[0] /= scale[0]
    shear[0] = float(np.dot(row[0], row[1]))
    row[1] -= row[0] * shear[0]
    scale[1] = vector_norm(row[1])
    row[1] /= scale[1]
    shear[0] /= scale[1]
    shear[1] = float(np.dot(row[0], row[2]))
    row[2] -= row[0] * shear[1]
    shear[2] = float(np.dot(row[1], row[2]))
    row[2] -= row[1] * shear[2]
    scale[2] = vector_norm(row[2])
    row[2] /= scale[2]
    shear[1:] /= scale[2]
    if np.dot(row[0], np.cross(row[1], row[2])) < 0:
        scale, row = -scale, -row
    angles[1] = math.asin(-row[0, 2])
    if math.cos(angles[1]):
        angles[0] = math.atan2(row[1, 2], row[2, 2])
        angles[2] = math.atan2(row[0, 1], row[0, 0])
    else:
        angles[0] = math.atan2(-row[2, 1], row[1, 1])
        angles[2] = 0.0
    return scale, shear, angles, translate, perspective


def __getattr__(name: str) -> Any:
    """A function tf had that is not here: one line naming it."""
    if name.startswith("__"):
        raise AttributeError(name)
    raise AttributeError(
        f"tf.transformations.{name} is not provided by kr210_sim's tf (it has the rotation, "
        "Euler, quaternion, translation, reflection, scaling and compose/decompose functions)"
    )
