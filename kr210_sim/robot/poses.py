"""Checks of the joint states and poses given to the kinematics, and the thread pool that
spreads large batches (numpy releases the GIL in its loops).

Every check raises :class:`ValueError` naming what is wrong: a wrong shape, NaN or inf, a bottom
row other than [0, 0, 0, 1], a rotation that is not orthonormal (beyond :data:`ORTHO_TOL`) or is
a reflection.
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
#: Tolerance of the rotation checks on input poses.
ORTHO_TOL = 1e-6
#: The single-pose check's quick test (see :func:`check_pose_flat`); 5.5 x it is under ORTHO_TOL.
_FAST_TOL = 1e-7
#: Poses per work chunk of the batch path: small enough that the temporaries stay in cache.
CHUNK = 16384
_POOL: ThreadPoolExecutor | None = None


def thread_pool() -> ThreadPoolExecutor:
    """The pool (at most 4 threads, made on first use) that works large batches chunk by chunk."""
    global _POOL
    if _POOL is None:
        _POOL = ThreadPoolExecutor(
            max_workers=max(1, min(4, os.cpu_count() or 1)), thread_name_prefix="kr210-ik"
        )
    return _POOL


def check_q(q: npt.ArrayLike) -> FloatArray:
    """Joint states [rad], shape (6,) or (N, 6), as a float array.

    Raises:
        ValueError: On a wrong shape, NaN or inf.
    """
    arr = np.asarray(q, dtype=np.float64)
    if arr.shape[-1:] != (6,) or arr.ndim not in (1, 2):
        raise ValueError(f"q must have shape (6,) or (N, 6), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError("q contains NaN or inf")
    return arr


def check_pose_flat(v: list[float]) -> None:
    """:func:`check_pose` for one pose given as its 16 entries row by row, in pure Python (under
    a microsecond: the single-pose IK reads a pose once, with one ``tolist``).

    A pose that passes every check in one expression returns at once; any other pose goes
    through the checks one by one, so that the message names the first that fails.
    """
    a, b, c, px, d, e, f, py, g, h, k, pz, b0, b1, b2, b3 = v
    # Columns u = (a, d, g), v = (b, e, h), w = (c, f, k). If |u|^2 - 1, |v|^2 - 1, u.v and each
    # entry of w - u x v are within _FAST_TOL, then |w|^2 - 1 <= 5.5 _FAST_TOL, u.w and v.w
    # <= 1.8 _FAST_TOL and det R > 0: inside ORTHO_TOL, in 27 products and sums instead of 44.
    # NaN fails every comparison and inf the norms, so a pose that passes is finite (its
    # translation checked on its own).
    if (
        -_FAST_TOL <= a * a + d * d + g * g - 1.0 <= _FAST_TOL
        and -_FAST_TOL <= b * b + e * e + h * h - 1.0 <= _FAST_TOL
        and -_FAST_TOL <= a * b + d * e + g * h <= _FAST_TOL
        and -_FAST_TOL <= c - (d * h - g * e) <= _FAST_TOL
        and -_FAST_TOL <= f - (g * b - a * h) <= _FAST_TOL
        and -_FAST_TOL <= k - (a * e - d * b) <= _FAST_TOL
        and b0 == 0.0
        and b1 == 0.0
        and b2 == 0.0
        and b3 == 1.0
        and math.isfinite(px + py + pz)
    ):
        return
    if not math.isfinite(a + b + c + d + e + f + g + h + k + px + py + pz + (b0 + b1 + b2 + b3)):
        raise ValueError("pose contains NaN or inf")
    if b0 != 0.0 or b1 != 0.0 or b2 != 0.0 or b3 != 1.0:
        raise ValueError("pose bottom row must be [0, 0, 0, 1]")
    err = max(
        abs(a * a + d * d + g * g - 1.0),
        abs(b * b + e * e + h * h - 1.0),
        abs(c * c + f * f + k * k - 1.0),
        abs(a * b + d * e + g * h),
        abs(a * c + d * f + g * k),
        abs(b * c + e * f + h * k),
    )
    if err > ORTHO_TOL:
        raise ValueError(f"pose rotation is not orthonormal (|R^T R - I| = {err:.2e})")
    if a * (e * k - f * h) - b * (d * k - f * g) + c * (d * h - e * g) < 0:
        raise ValueError("pose rotation is a reflection (det R = -1)")


def _check_pose_scalar(arr: FloatArray) -> None:
    """:func:`check_pose` for one (4, 4) pose, in pure Python."""
    check_pose_flat(arr.ravel().tolist())


def check_pose(T: npt.ArrayLike) -> FloatArray:
    """Poses, shape (4, 4) or (N, 4, 4), as a float array (batches above :data:`CHUNK` checked
    on the thread pool).

    Raises:
        ValueError: On a wrong shape, NaN or inf, a bad bottom row, a rotation that is not
            orthonormal or is a reflection.
    """
    arr = np.asarray(T, dtype=np.float64)
    if arr.shape == (4, 4):
        _check_pose_scalar(arr)
        return arr
    if arr.shape[-2:] != (4, 4) or arr.ndim not in (2, 3):
        raise ValueError(f"pose must have shape (4, 4) or (N, 4, 4), got {arr.shape}")
    n = arr.shape[0]
    if n <= CHUNK:
        checks = [_check_chunk(arr)]
    else:  # large batches: checked chunk by chunk on the thread pool, like the solve
        checks = list(
            thread_pool().map(lambda i: _check_chunk(arr[i : i + CHUNK]), range(0, n, CHUNK))
        )
    finite, bottom, err, det = (
        all(c[0] for c in checks),
        max(c[1] for c in checks),
        max(c[2] for c in checks),
        min(c[3] for c in checks),
    )
    if not finite:
        raise ValueError("pose contains NaN or inf")
    if bottom > 1e-12:
        raise ValueError("pose bottom row must be [0, 0, 0, 1]")
    if err > ORTHO_TOL:
        raise ValueError(f"pose rotation is not orthonormal (|R^T R - I| = {err:.2e})")
    if det < 0:
        raise ValueError("pose rotation is a reflection (det R = -1)")
    return arr


def _check_chunk(T: FloatArray) -> tuple[bool, float, float, float]:
    """(all finite, largest bottom-row deviation, largest |R^T R - I| entry, smallest det R)
    for poses (n, 4, 4), from elementwise products of contiguous rows (much faster than batched
    3x3 matmul and det in numpy)."""
    if not T.shape[0]:
        return True, 0.0, 0.0, 1.0
    flat = T.reshape(-1, 16).T.copy()  # (16, n), row k = entry (k // 4, k % 4)
    finite = bool(np.isfinite(flat).all())
    if not finite:
        return False, 0.0, 0.0, 1.0
    bottom = float(np.abs(flat[12:16] - np.array([[0.0], [0.0], [0.0], [1.0]])).max())
    r = [[flat[4 * i + j] for j in range(3)] for i in range(3)]
    err = np.zeros(flat.shape[1])
    for a in range(3):
        for b in range(a, 3):
            d = r[0][a] * r[0][b] + r[1][a] * r[1][b] + r[2][a] * r[2][b] - (a == b)
            np.maximum(err, np.abs(d), out=err)
    det = (
        r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1])
        - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0])
        + r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0])
    )
    return True, bottom, float(err.max()), float(det.min())
