"""A stereo depth camera's errors, added to MuJoCo's perfect images.

The figures are Intel's for its RealSense D400 active-stereo cameras:

* *Depth noise grows with the square of range.* Intel's D400 Series Product Family Datasheet
  gives the depth RMS error as ``RMS = z^2 * subpixel / (f * b)`` (z the range, ``f`` the focal
  length in pixels of the depth imager at its full resolution, ``f = 0.5 * Xres / tan(HFOV/2)``,
  ``b`` the stereo baseline), with a subpixel RMS of 0.08 px on a well-textured target. The
  model draws each pixel's disparity ``d = f * b / z`` with that RMS and turns it back to depth,
  which gives exactly this growth for small errors. D415: baseline 55 mm, HFOV 65 deg at
  1280 px (``f`` = 1004.6 px): 1.45 mm at 1 m, 5.8 mm at 2 m. D435: baseline 50 mm, HFOV 90 deg
  at 1280 px (``f`` = 640 px): 2.5 mm at 1 m, 10 mm at 2 m. The noise is the depth imager's, at
  its own resolution, whatever size the cell's sensor renders at.
* *Quantisation.* The D400's disparity has a 1/32 px step (Intel's white paper "Subpixel
  Linearity Improvement for Intel RealSense Depth Camera D400 Series"), so depth comes in steps
  of ``z^2 / (32 f b)`` (0.57 mm at 1 m on a D415), and the depth image's unit is 1 mm.
* *Missing pixels.* Stereo matching fails where the surface is seen edge-on (no pattern to
  match: the fraction missing rises linearly from none at :attr:`DepthNoise.grazing_start_deg`
  to all at :attr:`DepthNoise.grazing_end_deg` between the ray and the surface normal), on dark
  surfaces that return too little of the projector's light (below
  :attr:`DepthNoise.dark_luminance`), and on specular highlights that saturate the imagers
  (every colour channel at or above :attr:`DepthNoise.saturated`). These rates are not in the
  datasheet: they are the model's, set to match the holes the D400 leaves in practice, and
  tested as parameters.
* *Flying pixels.* Where depth jumps between neighbours (an object's silhouette against what
  is behind it), the matching window straddles both: a share of the edge pixels take a depth
  between the two.
* *RGB noise.* Read noise plus shot noise, ``sigma^2 = read^2 + gain * I`` in digital numbers;
  the datasheet gives no figure for the colour imager, so these are typical of a consumer CMOS
  colour sensor (an assumption, stated).

The model is seeded by the :class:`numpy.random.Generator` passed in, and a sensor whose
``noise`` is "none" skips it entirely (:func:`apply_noise` is not called).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from kr210_sim.perception.camera import Intrinsics

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class DepthNoise:
    """One sensor's noise model.

    Attributes:
        name: The model's name (a sensor's ``noise`` key).
        baseline: Stereo baseline [m].
        focal_px: The depth imager's focal length at its full resolution [px].
        subpixel_rms: RMS disparity error [px].
        disparity_step: Disparity quantisation step [px].
        depth_unit: Depth image's unit [m].
        grazing_start_deg: Incidence angle (ray to surface normal) where pixels start to go
            missing [deg].
        grazing_end_deg: Incidence angle where every pixel is missing [deg].
        dark_luminance: Luminance (0-1) below which pixels go missing, more the darker.
        dark_dropout: Share of missing pixels on a black surface.
        saturated: Colour value (0-255) at or above which, in every channel, a pixel is a
            specular highlight.
        saturated_dropout: Share of missing pixels on specular highlights.
        edge_jump: Relative depth jump between neighbours that makes an edge (of the nearer
            depth).
        flying_share: Share of edge pixels that fly (take a depth between the two sides).
        rgb_read: RGB read noise [DN].
        rgb_gain: RGB shot-noise gain [DN per DN].
    """

    name: str
    baseline: float
    focal_px: float
    subpixel_rms: float = 0.08
    disparity_step: float = 1.0 / 32.0
    depth_unit: float = 0.001
    grazing_start_deg: float = 70.0
    grazing_end_deg: float = 85.0
    dark_luminance: float = 0.06
    dark_dropout: float = 0.8
    saturated: int = 250
    saturated_dropout: float = 0.9
    edge_jump: float = 0.03
    flying_share: float = 0.5
    rgb_read: float = 1.5
    rgb_gain: float = 0.04

    def depth_rms(self, z: npt.ArrayLike) -> FloatArray:
        """The depth error's RMS at range ``z`` [m] (the datasheet's formula) [m]."""
        zz = np.asarray(z, dtype=np.float64)
        return zz * zz * self.subpixel_rms / (self.focal_px * self.baseline)

    def depth_step(self, z: npt.ArrayLike) -> FloatArray:
        """The depth step one disparity step makes at range ``z`` [m] [m]."""
        zz = np.asarray(z, dtype=np.float64)
        return zz * zz * self.disparity_step / (self.focal_px * self.baseline)

    def total_rms(self, z: npt.ArrayLike) -> FloatArray:
        """The RMS of what :func:`apply_noise` adds at range ``z`` [m], quantisation included:
        the noise and the two roundings (disparity, depth unit) as independent errors [m]."""
        return np.sqrt(
            self.depth_rms(z) ** 2 + self.depth_step(z) ** 2 / 12.0 + self.depth_unit**2 / 12.0
        )

    def grazing_dropout(self, incidence_deg: npt.ArrayLike) -> FloatArray:
        """Share of missing pixels at an incidence angle [deg]."""
        a = np.asarray(incidence_deg, dtype=np.float64)
        span = self.grazing_end_deg - self.grazing_start_deg
        return np.clip((a - self.grazing_start_deg) / span, 0.0, 1.0)


def _focal(hfov_deg: float, width: int = 1280) -> float:
    return 0.5 * width / math.tan(math.radians(hfov_deg) / 2.0)


#: The noise models a sensor may name: Intel RealSense D415 and D435 (datasheet figures).
MODELS: dict[str, DepthNoise] = {
    "d415": DepthNoise("d415", baseline=0.055, focal_px=_focal(65.0)),
    "d435": DepthNoise("d435", baseline=0.050, focal_px=_focal(90.0)),
}


def _incidence_cos(depth: npt.NDArray[np.floating], intrinsics: Intrinsics) -> FloatArray:
    """Cosine of the angle between each interior pixel's ray and the surface normal (float32,
    shape (H - 2, W - 2); NaN where the pixel or a neighbour is missing)."""
    z = np.asarray(depth, dtype=np.float32)
    h, w = z.shape
    x = ((np.arange(w, dtype=np.float32) - intrinsics.cx) / intrinsics.fx)[None, :]
    y = ((np.arange(h, dtype=np.float32) - intrinsics.cy) / intrinsics.fy)[:, None]
    X, Y = x * z, y * z
    # the tangents along the rows and the columns (interior pixels)
    ax = X[1:-1, 2:] - X[1:-1, :-2]
    ay = Y[1:-1, 2:] - Y[1:-1, :-2]
    az = z[1:-1, 2:] - z[1:-1, :-2]
    bx = X[2:, 1:-1] - X[:-2, 1:-1]
    by = Y[2:, 1:-1] - Y[:-2, 1:-1]
    bz = z[2:, 1:-1] - z[:-2, 1:-1]
    nx, ny, nz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
    rx, ry = x[:, 1:-1], y[1:-1, :]
    dot = np.abs(nx * rx + ny * ry + nz)
    norm = np.sqrt((nx * nx + ny * ny + nz * nz) * (rx * rx + ry * ry + 1.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        cos = np.clip(dot / norm, 0.0, 1.0)
    missing = z <= 0
    near_missing = missing[1:-1, 2:] | missing[1:-1, :-2] | missing[2:, 1:-1] | missing[:-2, 1:-1]
    cos[near_missing | missing[1:-1, 1:-1]] = np.nan
    return cos


def incidence_deg(depth: npt.NDArray[np.floating], intrinsics: Intrinsics) -> FloatArray:
    """Angle between each pixel's ray and the surface normal [deg], from the depth image's
    neighbours (central differences; NaN on the border and where a neighbour is missing)."""
    h, w = np.shape(depth)
    out = np.full((h, w), np.nan)
    with np.errstate(invalid="ignore"):
        out[1:-1, 1:-1] = np.degrees(np.arccos(_incidence_cos(depth, intrinsics)))
    return out


def _grazing_dropout(
    depth: npt.NDArray[np.floating], intrinsics: Intrinsics, model: DepthNoise
) -> npt.NDArray[np.float32]:
    """Each pixel's share of missing for its incidence (0 on the border and beside a missing
    pixel): :meth:`DepthNoise.grazing_dropout` of :func:`incidence_deg`, the angle worked out
    only where it passes :attr:`DepthNoise.grazing_start_deg` (the rest drop none)."""
    cos = _incidence_cos(depth, intrinsics)
    out = np.zeros(np.shape(depth), dtype=np.float32)
    with np.errstate(invalid="ignore"):
        steep = cos < np.float32(math.cos(math.radians(model.grazing_start_deg)))
    rows, cols = np.nonzero(steep)
    angle = np.degrees(np.arccos(cos[rows, cols]))
    out[rows + 1, cols + 1] = model.grazing_dropout(angle)
    return out


def _edge_partner(
    z: npt.NDArray[np.float32], jump: float
) -> tuple[npt.NDArray[np.bool_], npt.NDArray[np.float32]]:
    """Pixels at a depth edge, and the depth across it (the neighbour farthest in depth; of
    equal jumps, the first of right, left, below, above)."""
    best = np.zeros_like(z)
    partner = z.copy()
    d_h = np.abs(z[:, 1:] - z[:, :-1])
    d_v = np.abs(z[1:, :] - z[:-1, :])
    d_h[(z[:, 1:] <= 0) | (z[:, :-1] <= 0)] = 0.0
    d_v[(z[1:, :] <= 0) | (z[:-1, :] <= 0)] = 0.0
    for here, there, diff in (
        ((slice(None), slice(None, -1)), (slice(None), slice(1, None)), d_h),
        ((slice(None), slice(1, None)), (slice(None), slice(None, -1)), d_h),
        ((slice(None, -1), slice(None)), (slice(1, None), slice(None)), d_v),
        ((slice(1, None), slice(None)), (slice(None, -1), slice(None)), d_v),
    ):
        b, p = best[here], partner[here]  # views: written in place
        better = diff > b
        np.copyto(b, diff, where=better)
        np.copyto(p, z[there], where=better)
    edge = (z > 0) & (best > np.float32(jump) * np.minimum(z, partner))
    return edge, partner


def apply_noise(
    rgb: npt.NDArray[np.uint8],
    depth: npt.NDArray[np.floating],
    intrinsics: Intrinsics,
    model: DepthNoise,
    rng: np.random.Generator,
) -> tuple[npt.NDArray[np.uint8], npt.NDArray[np.float32]]:
    """A sensor's images from perfect ones.

    Args:
        rgb: (H, W, 3) perfect colour image.
        depth: (H, W) perfect depth along the optical axis [m] (0: nothing).
        intrinsics: The sensor's intrinsics.
        model: The noise model.
        rng: The generator drawn from (the only source of randomness).

    Returns:
        The noisy colour image and depth image [m] (0 marks a missing pixel), float32.
    """
    z = np.asarray(depth, dtype=np.float32)
    valid = z > 0
    # flying pixels: a share of edge pixels take a depth between the two sides
    edge, partner = _edge_partner(z, model.edge_jump)
    rows, cols = np.nonzero(edge)
    fly = rng.random(len(rows)) < model.flying_share
    rows, cols = rows[fly], cols[fly]
    t = rng.uniform(0.1, 0.9, size=len(rows)).astype(np.float32)
    z_true = z.copy()
    z_true[rows, cols] += t * (partner[rows, cols] - z[rows, cols])
    # missing pixels, judged on the perfect images (an edge's slope is no surface's: the edge
    # has its flying pixels instead)
    p_miss = _grazing_dropout(z, intrinsics, model)
    p_miss[edge] = 0.0
    lum = (rgb.astype(np.float32) @ np.array([0.299, 0.587, 0.114], dtype=np.float32)) / 255.0
    dark = lum < model.dark_luminance
    if dark.any():
        share = model.dark_dropout * (model.dark_luminance - lum[dark]) / model.dark_luminance
        p_miss[dark] = 1.0 - (1.0 - p_miss[dark]) * (1.0 - share)
    shiny = np.minimum(np.minimum(rgb[..., 0], rgb[..., 1]), rgb[..., 2]) >= model.saturated
    if shiny.any():
        p_miss[shiny] = 1.0 - (1.0 - p_miss[shiny]) * (1.0 - model.saturated_dropout)
    # range noise in disparity, its 1/32 px step, and the 1 mm unit
    fb = np.float32(model.focal_px * model.baseline)
    with np.errstate(divide="ignore"):
        disparity = np.where(valid, fb / np.where(valid, z_true, np.float32(1.0)), np.float32(0.0))
    disparity += rng.standard_normal(z.shape, dtype=np.float32) * np.float32(model.subpixel_rms)
    step = np.float32(model.disparity_step)
    disparity = np.round(disparity / step) * step
    ok = valid & (disparity > 0)
    with np.errstate(divide="ignore"):
        noisy = fb / disparity
    unit = np.float32(model.depth_unit)
    noisy = np.round(noisy / unit) * unit
    missing = rng.random(z.shape, dtype=np.float32) < p_miss
    noisy[missing | ~ok] = 0.0
    # colour: read and shot noise
    levels = np.arange(256, dtype=np.float32)  # sigma of each 8-bit level, looked up
    sigma = np.sqrt(np.float32(model.rgb_read**2) + np.float32(model.rgb_gain) * levels)
    img = rgb.astype(np.float32)
    img += rng.standard_normal(img.shape, dtype=np.float32) * sigma[rgb]
    return np.clip(np.round(img), 0, 255).astype(np.uint8), noisy.astype(np.float32, copy=False)
