"""The shelf's boards, posts and back panel found by RANSAC and taken out of a bay's cloud.

Each face of the bay's box (the board under it, the board above, the two posts, the back panel;
the front is open) is looked for near where the layout puts it: RANSAC fits the face's
coordinate as a linear function of the other two (:func:`ransac_plane`). It draws all its
hypotheses at once in numpy: scikit-learn's ``RANSACRegressor`` does the same job at about 1 ms
a hypothesis (25 ms a face, measured here), over the whole 100 ms budget of a look for five
faces, and Open3D's ``segment_plane`` needs a system library (libusb) that the setup commands
cannot install. A plane is accepted only inside clear
limits: tilted at most :data:`MAX_TILT_DEG` from the face, shifted at most :data:`MAX_SHIFT`
from it, and holding enough inliers. Everything on or behind an accepted plane (within its noise)
goes; a face not found is taken out where the layout puts it. A board or back panel not found
or off the layout, or a surface seen under the board, is the sign of a wrong extrinsic, and the
result says so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]

#: Largest tilt of a plane from the face it stands for [deg].
MAX_TILT_DEG = 6.0
#: Largest shift of a plane from where the layout puts its face [m].
MAX_SHIFT = 0.04
#: Fewest inliers a plane needs.
MIN_INLIERS = 60
#: Points RANSAC draws from at most (the inliers are then counted on all).
RANSAC_POINTS = 400
#: The bounds of the band [m] taken out in front of a plane: 3 sigma of its inliers, clipped.
BAND = (0.006, 0.035)

#: The faces: name, the axis of the box frame normal to it, and the side (+1: at +half).
FACES = (
    ("board", 2, -1),
    ("board above", 2, +1),
    ("back panel", 0, +1),
    ("left post", 1, +1),
    ("right post", 1, -1),
)


@dataclass(frozen=True)
class PlaneFit:
    """One face's plane.

    Attributes:
        face: The face's name.
        found: Whether RANSAC found a plane within the limits.
        shift: Signed distance of the plane from the layout's face, along the face's outward
            normal [m] (at the box's centre); 0 when not found.
        tilt_deg: Tilt from the face [deg]; 0 when not found.
        band: Thickness of what was taken out in front of the plane [m].
        inliers: Points within the band.
        note: Why it was not found, when it was not.
        coef: (a, b, c) of the plane ``coord = a u + b v + c`` over the face's two other
            coordinates (in axis order) in the box frame [m]; the layout's face when not found.
    """

    face: str
    found: bool
    shift: float
    tilt_deg: float
    band: float
    inliers: int
    note: str = ""
    coef: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class ShelfRemoval:
    """What :func:`remove_shelf` kept and found.

    Attributes:
        keep: (N,) mask of the points that are not the shelf.
        planes: One fit per face, in :data:`FACES` order.
        problems: Clear reasons the cloud cannot be trusted (empty when it can).
    """

    keep: npt.NDArray[np.bool_]
    planes: tuple[PlaneFit, ...]
    problems: tuple[str, ...]


def ransac_plane(
    X: FloatArray,
    y: FloatArray,
    threshold: float,
    rng: np.random.Generator,
    trials: int = 64,
    max_slope: float | None = None,
    offset_range: tuple[float, float] | None = None,
) -> tuple[tuple[float, float, float], npt.NDArray[np.bool_]]:
    """RANSAC for ``y = a x0 + b x1 + c``: the hypothesis through three drawn points with the
    most inliers, refitted by least squares on them.

    Args:
        X: (N, 2) the two free coordinates [m].
        y: (N,) the fitted coordinate [m].
        threshold: Largest residual of an inlier [m].
        rng: Draws the samples.
        trials: Hypotheses drawn.
        max_slope: Hypotheses steeper than this (hypot(a, b)) are not counted.
        offset_range: Hypotheses whose c lies outside it are not counted [m].

    Returns:
        (a, b, c) and the (N,) inlier mask of the refitted plane; NaNs and no inliers when no
        hypothesis is within the limits.
    """
    A = np.column_stack((X, np.ones(len(X))))
    picks = rng.random((trials, len(X))).argsort(axis=1)[:, :3]
    M = A[picks]
    ok = np.abs(np.linalg.det(M)) > 1e-12
    sol = np.full((trials, 3), np.nan)
    sol[ok] = np.linalg.solve(M[ok], y[picks][ok][..., None])[..., 0]
    good = np.all(np.isfinite(sol), axis=1)
    if max_slope is not None:
        good &= np.hypot(sol[:, 0], sol[:, 1]) <= max_slope
    if offset_range is not None:
        good &= (sol[:, 2] >= offset_range[0]) & (sol[:, 2] <= offset_range[1])
    if not np.any(good):
        return (math.nan, math.nan, math.nan), np.zeros(len(X), dtype=bool)
    res = np.abs(A @ sol[good].T - y[:, None])
    counts = np.count_nonzero(res <= threshold, axis=0)
    best = sol[good][int(np.argmax(counts))]
    inl = np.abs(A @ best - y) <= threshold
    refit = np.linalg.lstsq(A[inl], y[inl], rcond=None)[0]
    inl = np.abs(A @ refit - y) <= threshold
    return (float(refit[0]), float(refit[1]), float(refit[2])), inl


def _fit_face(
    local: FloatArray, half: FloatArray, axis: int, side: int, rng: np.random.Generator
) -> tuple[PlaneFit, FloatArray]:
    """RANSAC for one face; returns the fit and each point's distance in front of the plane
    (towards the box's inside) [m]."""
    others = [a for a in range(3) if a != axis]
    nominal = side * half[axis]
    inward = -side * (local[:, axis] - nominal)  # distance inside the nominal face
    nominal_coef = (0.0, 0.0, float(nominal))
    window = np.abs(inward) <= MAX_SHIFT + BAND[1]
    n = int(np.count_nonzero(window))
    name = next(f for f, a, s in FACES if a == axis and s == side)
    if n < MIN_INLIERS:
        note = f"{n} points near it"
        return PlaneFit(name, False, 0.0, 0.0, BAND[0], 0, note, nominal_coef), inward
    idx = np.flatnonzero(window)
    if n > RANSAC_POINTS:
        idx = rng.choice(idx, RANSAC_POINTS, replace=False)
    X = local[idx][:, others]
    y = local[idx, axis]
    slope = math.tan(math.radians(MAX_TILT_DEG))
    span = (nominal - MAX_SHIFT - 0.2 * slope, nominal + MAX_SHIFT + 0.2 * slope)
    (a, b, c), inl = ransac_plane(X, y, BAND[1] / 2.0, rng, max_slope=slope, offset_range=span)
    if np.count_nonzero(inl) < 3:
        note = "no plane within the limits near it"
        return PlaneFit(name, False, 0.0, 0.0, BAND[0], 0, note, nominal_coef), inward
    tilt = math.degrees(math.atan(math.hypot(a, b)))
    res = y[inl] - (X[inl] @ np.array([a, b]) + c)
    sigma = 1.4826 * float(np.median(np.abs(res - np.median(res))))
    band = float(np.clip(3.0 * sigma, *BAND))
    plane = local[:, others] @ np.array([a, b]) + c
    dist = -side * (local[:, axis] - plane) * math.cos(math.radians(tilt))
    inliers = int(np.count_nonzero(np.abs(dist) <= band))
    shift = side * (c - nominal)
    if tilt > MAX_TILT_DEG or abs(shift) > MAX_SHIFT or inliers < MIN_INLIERS:
        note = f"plane at {shift * 1000:+.0f} mm, tilted {tilt:.1f} deg, {inliers} inliers"
        return PlaneFit(name, False, shift, tilt, BAND[0], inliers, note, nominal_coef), inward
    return PlaneFit(name, True, shift, tilt, band, inliers, "", (a, b, c)), dist


#: The faces a look must find where the layout puts them (the board, and the back panel that
#: fixes the depth): else its extrinsic cannot be trusted. The posts and the board above are
#: taken out but not required: from the fixed sensor's viewpoint one sees mostly their front
#: edges, which RANSAC can mistake within the limits.
REQUIRED = ("board", "back panel")
#: Fewest points under the fitted board that call it a false board.
MIN_UNDER = 50


def _under_board(local: FloatArray, half: FloatArray, dist: FloatArray, fit: PlaneFit) -> int:
    """How many points lie well under a found board within the bay's footprint (0 when fewer
    than :data:`MIN_UNDER` or a fifth of the board's inliers): the board is opaque, so a
    surface seen through it means the plane found is not the board (objects' bottoms seen
    through a wrong extrinsic, the true board lower down). The front 10 cm are left out: the
    beam under a rack's deck and the flying pixels of the deck's front edge lie there."""
    if not fit.found:
        return 0
    inner = np.all(np.abs(local[:, :2]) <= half[:2] - 0.03, axis=1) & (local[:, 0] > -half[0] + 0.1)
    n = int(np.count_nonzero(inner & (dist < -2.0 * fit.band - 0.01)))
    return n if n >= max(MIN_UNDER, fit.inliers // 5) else 0


def remove_shelf(
    local: FloatArray,
    half: npt.ArrayLike,
    rng: np.random.Generator,
    max_shift: float = 0.03,
    required: tuple[str, ...] = REQUIRED,
) -> ShelfRemoval:
    """Take the bay's boards, posts and back panel out of its cloud.

    Args:
        local: (N, 3) points in the bay's box frame [m] (cropped with a margin, so that the
            faces are in it, and with more below the floor: a board that is not the board
            shows by what is seen under it).
        half: The box's half extents [m].
        rng: Seeds RANSAC's draws.
        max_shift: Largest shift of a required face from the layout's before the cloud is
            called untrustworthy (a wrong extrinsic) [m]. The rendered rack's faces lie up to
            2 cm off the collision shelf's (its deck 2 cm under the board's top, its uprights
            narrower than the posts): 3 cm allows for that.
        required: The faces that must be found (the board is left out when the camera sees
            it edge-on or from below).

    Returns:
        The mask of what is not the shelf, each face's plane and the problems found.
    """
    h = np.asarray(half, dtype=np.float64)
    keep = np.ones(len(local), dtype=bool)
    fits = []
    problems = []
    check = "is the sensor's extrinsic right?"
    for name, axis, side in FACES:
        fit, dist = _fit_face(local, h, axis, side, rng)
        fits.append(fit)
        keep &= dist > fit.band
        if name == "board" and (under := _under_board(local, h, dist, fit)):
            problems.append(
                f"{under} points lie under the bay's board as fitted, a surface below it: {check}"
            )
        elif name in required and not fit.found:
            problems.append(
                f"the bay's {name} is not where the layout puts it ({fit.note}): {check}"
            )
        elif name in required and abs(fit.shift) > max_shift:
            problems.append(
                f"the bay's {name} is {fit.shift * 1000:+.0f} mm off the layout's: {check}"
            )
    return ShelfRemoval(keep, tuple(fits), tuple(problems))
