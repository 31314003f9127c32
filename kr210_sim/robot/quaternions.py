"""Unit quaternions as ROS writes them, ``(x, y, z, w)``, and the rotation matrices they stand for.

ROS messages (``geometry_msgs/Quaternion``) and the original exercise's ``tf`` order the scalar
part last; a pose ``(position, quaternion)`` of gripper_link in base_link is the 4x4 transform
``T_base_gripper`` the kinematics use.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]


def rotation_from_quaternion(xyzw: Sequence[float]) -> FloatArray:
    """The rotation matrix (3x3) of the quaternion ``(x, y, z, w)``, normalised first.

    Raises:
        ValueError: For a quaternion of (near) zero length, or one that is not four finite
            numbers.
    """
    q = np.asarray(xyzw, dtype=np.float64).reshape(-1)
    norm = float(np.linalg.norm(q)) if q.shape == (4,) else math.nan
    if not (math.isfinite(norm) and norm > 1e-12):
        raise ValueError(f"a quaternion must be four finite numbers, not all 0; got {list(q)}")
    x, y, z, w = q / norm
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def quaternion_from_rotation(R: npt.ArrayLike) -> tuple[float, float, float, float]:
    """The unit quaternion ``(x, y, z, w)`` of rotation matrix ``R`` (3x3), with ``w >= 0``.

    Shepperd's method: the largest of the four squared components is taken from the diagonal
    and the others from the off-diagonal sums, so the result is accurate for every rotation.
    """
    m = np.asarray(R, dtype=np.float64)[:3, :3]
    t = float(np.trace(m))
    cand = (t, float(m[0, 0]), float(m[1, 1]), float(m[2, 2]))
    k = int(np.argmax(cand))
    if k == 0:
        s = 2.0 * math.sqrt(1.0 + t)
        w, x, y, z = (
            s / 4,
            (m[2, 1] - m[1, 2]) / s,
            (m[0, 2] - m[2, 0]) / s,
            (m[1, 0] - m[0, 1]) / s,
        )
    elif k == 1:
        s = 2.0 * math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        w, x, y, z = (
            (m[2, 1] - m[1, 2]) / s,
            s / 4,
            (m[0, 1] + m[1, 0]) / s,
            (m[0, 2] + m[2, 0]) / s,
        )
    elif k == 2:
        s = 2.0 * math.sqrt(1.0 - m[0, 0] + m[1, 1] - m[2, 2])
        w, x, y, z = (
            (m[0, 2] - m[2, 0]) / s,
            (m[0, 1] + m[1, 0]) / s,
            s / 4,
            (m[1, 2] + m[2, 1]) / s,
        )
    else:
        s = 2.0 * math.sqrt(1.0 - m[0, 0] - m[1, 1] + m[2, 2])
        w, x, y, z = (
            (m[1, 0] - m[0, 1]) / s,
            (m[0, 2] + m[2, 0]) / s,
            (m[1, 2] + m[2, 1]) / s,
            s / 4,
        )
    sign = -1.0 if w < 0 else 1.0
    return (sign * float(x), sign * float(y), sign * float(z), sign * float(w))


def pose_matrix(position: Sequence[float], xyzw: Sequence[float]) -> FloatArray:
    """``T`` (4x4) of a pose given as a position [m] and a quaternion ``(x, y, z, w)``."""
    T = np.eye(4)
    T[:3, :3] = rotation_from_quaternion(xyzw)
    T[:3, 3] = np.asarray(position, dtype=np.float64).reshape(3)
    return T
