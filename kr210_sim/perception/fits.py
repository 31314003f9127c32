"""A pose per kind from one cluster: a cylinder's axis, radius and centre; a box's oriented frame;
a sphere's centre.

The points are in a frame whose z is up and whose floor (the board the objects stand on) is at
``floor_z`` [m]; the camera sees one side of each object, so every fit works from what is
visible: the cylinder's circle is fitted to the visible arc (SciPy's least squares, with a soft
L1 loss against the noise's tails), the box's faces are found from the normals, the sphere's
centre from its cap. Where the visible part cannot fix a size (a narrow arc seen from far), the
kind's nominal size is used and the pose says so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.optimize import least_squares

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Fit:
    """A fitted pose in the cluster's frame.

    Attributes:
        position: The object's centre [m].
        axis: Unit axis (z for a box's or a sphere's).
        frame: 3 x 3 rotation whose columns are the object's x, y, z.
        size: Fitted size as the kind gives it [m].
        residual: RMS distance of the points to the fitted surface [m].
        measured_size: Whether the size was measured (else the nominal one was used).
    """

    position: FloatArray
    axis: FloatArray
    frame: FloatArray
    size: tuple[float, ...]
    residual: float
    measured_size: bool


def _circle(xy: FloatArray) -> tuple[FloatArray, float]:
    """Kasa's algebraic circle through ``xy``: centre [m] and radius [m]."""
    A = np.column_stack((2.0 * xy, np.ones(len(xy))))
    b = np.sum(xy * xy, axis=1)
    sol = np.linalg.lstsq(A, b, rcond=None)[0]
    c = sol[:2]
    return c, float(math.sqrt(max(sol[2] + c @ c, 1e-12)))


def _top(points: FloatArray, normals: FloatArray) -> float:
    """z of an upright object's top [m]: the median of its top face's points when it shows,
    else the 99.5th percentile of the points' z."""
    high = float(np.percentile(points[:, 2], 99.5))
    cap = (np.abs(normals[:, 2]) > 0.8) & (points[:, 2] > high - 0.03)
    if np.count_nonzero(cap) >= 10:
        return float(np.median(points[cap, 2]))
    return high


def _frame_from_axis(axis: FloatArray) -> FloatArray:
    """A rotation whose z column is ``axis``."""
    x = np.cross([0.0, 1.0, 0.0], axis)
    x /= np.linalg.norm(x)
    return np.column_stack((x, np.cross(axis, x), axis))


def fit_cylinder(
    points: FloatArray,
    normals: FloatArray,
    floor_z: float,
    nominal_radius: float | None = None,
    toward_camera: FloatArray | None = None,
) -> Fit:
    """An upright cylinder's axis, radius and centre from the visible part of its side.

    A first fit to the side's points (normals within 53 deg of horizontal) gives the noise at
    the cylinder (the robust spread of the residuals). When the noise is over 4 % of the kind's
    radius (a far look) the arc cannot fix the radius: the kind's is used, the axis is kept
    upright, and the fit is repeated on the points that face the camera (within 60 deg), whose
    depth noise lies along the surface's normal rather than along the surface, where it would
    pull the circle towards the camera. Otherwise the radius and the axis's tilt are fitted.

    Args:
        points: (N, 3) the cluster's points [m], z up.
        normals: (N, 3) their unit normals.
        floor_z: z of the board it stands on [m].
        nominal_radius: The kind's radius [m].
        toward_camera: Horizontal direction from the cylinder towards the camera.
    """
    side = np.abs(normals[:, 2]) < 0.6
    p = points[side] if np.count_nonzero(side) >= 10 else points
    c0, r0 = _circle(p[:, :2])
    zc = float(np.mean(p[:, 2]))

    def residual(x: FloatArray, q: FloatArray, radius: float | None) -> FloatArray:
        axis = np.array([x[2], x[3], 1.0])
        axis /= np.linalg.norm(axis)
        d = q - np.array([x[0], x[1], zc])
        perp = d - np.outer(d @ axis, axis)
        return np.linalg.norm(perp, axis=1) - (x[4] if radius is None else radius)

    def circle_jac(v: FloatArray, q: FloatArray, radius: float | None) -> FloatArray:
        d = q[:, :2] - v[:2]
        n = np.linalg.norm(d, axis=1, keepdims=True)
        J = -d / np.maximum(n, 1e-12)
        return J if radius is not None else np.column_stack((J, -np.ones(len(q))))

    def circle_res(v: FloatArray, q: FloatArray, radius: float | None) -> FloatArray:
        r = v[2] if radius is None else radius
        return np.linalg.norm(q[:, :2] - v[:2], axis=1) - r

    def solve(
        x0: FloatArray, q: FloatArray, radius: float | None, scale: float, tilt: bool = True
    ) -> FloatArray:
        """The upright circle (analytic Jacobian), then, when the radius is measured (a close,
        quiet look), the axis's tilt too."""
        v0 = x0[[0, 1, 4]] if radius is None else x0[:2]
        v = least_squares(
            circle_res, v0, jac=circle_jac, args=(q, radius), loss="soft_l1", f_scale=scale
        ).x
        x = np.array([v[0], v[1], 0.0, 0.0, v[2] if radius is None else radius])
        if tilt and radius is None and len(q) >= 30:
            x = least_squares(residual, x, args=(q, None), loss="soft_l1", f_scale=scale).x
        return x

    x = solve(np.array([*c0, 0.0, 0.0, r0]), p, None, 0.002, tilt=False)
    res = residual(x, p, None)
    noise = 1.4826 * float(np.median(np.abs(res - np.median(res))))
    scale = max(noise, 5e-4)
    fixed = nominal_radius is not None and (
        noise > 0.04 * nominal_radius or abs(x[4] - nominal_radius) > 0.25 * nominal_radius
    )
    radius = nominal_radius if fixed else None
    x = solve(x, p, radius, scale)
    if fixed and toward_camera is not None:
        cam = np.asarray(toward_camera[:2], dtype=np.float64)
        cam /= max(float(np.linalg.norm(cam)), 1e-12)
        rad = p[:, :2] - x[:2]
        facing = rad @ cam > 0.5 * np.linalg.norm(rad, axis=1)
        if np.count_nonzero(facing) >= 10:
            p = p[facing]
            x = solve(x, p, radius, scale)
    axis = np.array([x[2], x[3], 1.0])
    axis /= np.linalg.norm(axis)
    top = _top(points, normals)
    mid_z = 0.5 * (top + floor_z)
    centre = np.array([x[0], x[1], zc]) + axis * (mid_z - zc) / axis[2]
    rms = float(np.sqrt(np.mean(residual(x, p, float(x[4])) ** 2)))
    return Fit(centre, axis, _frame_from_axis(axis), (float(x[4]), top - floor_z), rms, not fixed)


def fit_sphere(points: FloatArray, nominal_radius: float | None = None) -> Fit:
    """A sphere's centre (and radius) from its visible cap, by least squares.

    Args:
        points: (N, 3) the cluster's points [m].
        nominal_radius: The kind's radius [m], used when the fitted one is off by over 25 %.
    """
    A = np.column_stack((2.0 * points, np.ones(len(points))))
    sol = np.linalg.lstsq(A, np.sum(points * points, axis=1), rcond=None)[0]
    c = sol[:3]
    r = float(math.sqrt(max(sol[3] + c @ c, 1e-12)))
    measured = True
    if nominal_radius is not None and abs(r - nominal_radius) > 0.25 * nominal_radius:
        fit = least_squares(
            lambda v: np.linalg.norm(points - v, axis=1) - nominal_radius, c, loss="soft_l1"
        )
        c, r, measured = fit.x, nominal_radius, False
    res = float(np.sqrt(np.mean((np.linalg.norm(points - c, axis=1) - r) ** 2)))
    return Fit(c, np.array([0.0, 0.0, 1.0]), np.eye(3), (r,), res, measured)


def fit_box(
    points: FloatArray,
    normals: FloatArray,
    floor_z: float,
    toward_camera: FloatArray,
    nominal_size: tuple[float, float, float] | None = None,
) -> Fit:
    """An upright box's yaw, extents and centre from its visible faces.

    The yaw comes from the side faces' normals (their angle, taken modulo 90 deg); along each
    horizontal edge the centre is the middle of the points' span, or, when the span is shorter
    than the kind's edge (the far face hidden), half the edge behind the face seen.

    Args:
        points: (N, 3) the cluster's points [m].
        normals: (N, 3) their unit normals.
        floor_z: z of the board it stands on [m].
        toward_camera: Horizontal direction from the box towards the camera (unit or not).
        nominal_size: The kind's full extents (x, y, z) [m].
    """
    side = np.abs(normals[:, 2]) < 0.5
    n = normals[side] if np.count_nonzero(side) >= 10 else normals
    ang = np.arctan2(n[:, 1], n[:, 0])
    w = np.hypot(n[:, 0], n[:, 1])
    yaw = 0.25 * math.atan2(float(np.sum(w * np.sin(4 * ang))), float(np.sum(w * np.cos(4 * ang))))
    c, s = math.cos(yaw), math.sin(yaw)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    local = points @ R
    cam = R.T @ np.array([toward_camera[0], toward_camera[1], 0.0])
    lo, hi = np.percentile(local[:, :2], [1.0, 99.0], axis=0)
    span = hi - lo
    nominal = None if nominal_size is None else np.asarray(nominal_size[:2])
    if nominal is not None:  # match the box's x and y edges to the spans seen
        swap = abs(span[0] - nominal[1]) + abs(span[1] - nominal[0]) < abs(
            span[0] - nominal[0]
        ) + abs(span[1] - nominal[1])
        if swap:
            nominal = nominal[::-1]
    centre_xy = 0.5 * (lo + hi)
    measured = True
    if nominal is not None:
        for i in range(2):
            if span[i] < 0.8 * nominal[i]:
                measured = False
                centre_xy[i] = hi[i] - nominal[i] / 2 if cam[i] > 0 else lo[i] + nominal[i] / 2
    top = _top(points, normals)
    centre = R @ np.array([centre_xy[0], centre_xy[1], 0.5 * (top + floor_z)])
    size = tuple(float(v) for v in (nominal if nominal is not None and not measured else span))
    d = np.abs(local[:, :2] - centre_xy)
    half = np.asarray(size) / 2.0
    res = float(np.sqrt(np.mean(np.min(np.abs(d - half), axis=1) ** 2)))
    return Fit(centre, R[:, 2], R, (*size, top - floor_z), res, measured)
