"""Analytic depth images of simple scenes: a ray caster for tests that need no renderer.

Each primitive (an oriented box, an upright cylinder, a sphere) is intersected with every pixel's
ray in closed form; the nearest hit gives the pixel's depth along the optical axis and a shaded
colour. Independent of MuJoCo, it lets the pipeline's steps be checked against exact geometry,
and its images cross-check what the simulated sensors render.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from kr210_sim.perception.camera import Intrinsics, Observation

FloatArray = npt.NDArray[np.float64]

#: Direction towards the light (base frame), for Lambertian shading.
LIGHT = np.array([-0.5, -0.3, 0.8]) / np.linalg.norm([-0.5, -0.3, 0.8])


@dataclass(frozen=True)
class Primitive:
    """One solid of a scene.

    Attributes:
        shape: "box", "cylinder" (upright: its axis along the base frame's z) or "sphere".
        centre: Centre [m] in the base frame.
        size: box half extents (3), cylinder (radius, half length), sphere (radius,) [m].
        yaw: A box's rotation about z [rad].
        rgb: Colour, each channel in [0, 1].
        label: The object's name (empty for the shelf's parts).
    """

    shape: str
    centre: tuple[float, float, float]
    size: tuple[float, ...]
    rgb: tuple[float, float, float]
    yaw: float = 0.0
    label: str = ""


def _rays(intrinsics: Intrinsics) -> FloatArray:
    """(H*W, 3) camera-frame ray directions scaled so that their z is 1 (t = depth)."""
    u = (np.arange(intrinsics.width) - intrinsics.cx) / intrinsics.fx
    v = (np.arange(intrinsics.height) - intrinsics.cy) / intrinsics.fy
    uu, vv = np.meshgrid(u, v)
    return np.column_stack((uu.ravel(), vv.ravel(), np.ones(uu.size)))


def _hit_box(o: FloatArray, d: FloatArray, p: Primitive) -> tuple[FloatArray, FloatArray]:
    """Ray parameter of the entry into an oriented box and the normal there (slab method)."""
    c, s = np.cos(p.yaw), np.sin(p.yaw)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    ol = (o - np.asarray(p.centre)) @ R
    dl = d @ R
    h = np.asarray(p.size)
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (-h - ol) / dl
        t2 = (h - ol) / dl
    tmin = np.fmin(t1, t2)
    tmax = np.fmax(t1, t2)
    t_in = np.max(tmin, axis=1)
    t_out = np.min(tmax, axis=1)
    ok = (t_in <= t_out) & (t_in > 0.0)
    axis = np.argmax(tmin, axis=1)
    nl = np.zeros_like(dl)
    idx = np.arange(len(dl))
    nl[idx, axis] = -np.sign(dl[idx, axis])
    return np.where(ok, t_in, np.inf), nl @ R.T


def _hit_cylinder(o: FloatArray, d: FloatArray, p: Primitive) -> tuple[FloatArray, FloatArray]:
    """Ray parameter of the entry into an upright cylinder (side or caps) and the normal."""
    r, hl = p.size
    c = np.asarray(p.centre)
    oc = o - c
    a = d[:, 0] ** 2 + d[:, 1] ** 2
    b = 2.0 * (oc[0] * d[:, 0] + oc[1] * d[:, 1])
    cc = oc[0] ** 2 + oc[1] ** 2 - r * r
    disc = b * b - 4.0 * a * cc
    with np.errstate(invalid="ignore", divide="ignore"):
        t_side = (-b - np.sqrt(disc)) / (2.0 * a)
    z_side = oc[2] + t_side * d[:, 2]
    side_ok = (disc >= 0.0) & (t_side > 0.0) & (np.abs(z_side) <= hl)
    t_side = np.where(side_ok, t_side, np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_top = (hl - oc[2]) / d[:, 2]
        t_bot = (-hl - oc[2]) / d[:, 2]
    t_cap = np.where(oc[2] > hl, t_top, t_bot)
    q = oc + t_cap[:, None] * d
    cap_ok = (t_cap > 0.0) & (q[:, 0] ** 2 + q[:, 1] ** 2 <= r * r) & (abs(oc[2]) > hl)
    t_cap = np.where(cap_ok, t_cap, np.inf)
    t = np.minimum(t_side, t_cap)
    pts = oc + np.where(np.isfinite(t), t, 0.0)[:, None] * d
    n = np.column_stack((pts[:, 0], pts[:, 1], np.zeros(len(d))))
    n /= np.maximum(np.linalg.norm(n, axis=1), 1e-12)[:, None]
    n[t_cap < t_side] = (0.0, 0.0, 1.0 if oc[2] > hl else -1.0)
    return t, n


def _hit_sphere(o: FloatArray, d: FloatArray, p: Primitive) -> tuple[FloatArray, FloatArray]:
    """Ray parameter of the entry into a sphere and the normal there."""
    r = p.size[0]
    oc = o - np.asarray(p.centre)
    a = np.sum(d * d, axis=1)
    b = 2.0 * (d @ oc)
    cc = oc @ oc - r * r
    disc = b * b - 4.0 * a * cc
    with np.errstate(invalid="ignore"):
        t = (-b - np.sqrt(disc)) / (2.0 * a)
    t = np.where((disc >= 0.0) & (t > 0.0), t, np.inf)
    n = (oc + np.where(np.isfinite(t), t, 0.0)[:, None] * d) / r
    return t, n


_HITS = {"box": _hit_box, "cylinder": _hit_cylinder, "sphere": _hit_sphere}


@dataclass(frozen=True)
class Cast:
    """What a ray cast gives: the noise-free image and which primitive each pixel sees.

    Attributes:
        depth: (H, W) depth along the optical axis [m], 0 where no primitive is hit.
        rgb: (H, W, 3) shaded colour, uint8.
        index: (H, W) index of the primitive each pixel sees, -1 for none.
        cos_incidence: (H, W) cosine between the ray and the surface normal (0 for none).
    """

    depth: npt.NDArray[np.float32]
    rgb: npt.NDArray[np.uint8]
    index: npt.NDArray[np.int64]
    cos_incidence: FloatArray


def cast(primitives: list[Primitive], intrinsics: Intrinsics, T_base_camera: npt.ArrayLike) -> Cast:
    """Ray-cast ``primitives`` from a pinhole camera.

    Args:
        primitives: The scene's solids, in the base frame.
        intrinsics: The camera's intrinsics.
        T_base_camera: 4 x 4 pose of the optical frame in the base frame [m].
    """
    T = np.asarray(T_base_camera, dtype=np.float64)
    d_cam = _rays(intrinsics)
    d = d_cam @ T[:3, :3].T
    o = T[:3, 3]
    best = np.full(len(d), np.inf)
    normal = np.zeros_like(d)
    index = np.full(len(d), -1, dtype=np.int64)
    for i, p in enumerate(primitives):
        t, n = _HITS[p.shape](o, d, p)
        closer = t < best
        best[closer] = t[closer]
        normal[closer] = n[closer]
        index[closer] = i
    hit = np.isfinite(best)
    unit = d / np.linalg.norm(d, axis=1)[:, None]
    cos_inc = np.where(hit, np.abs(np.sum(unit * normal, axis=1)), 0.0)
    colours = np.array([p.rgb for p in primitives] + [(0.0, 0.0, 0.0)])
    shade = 0.45 + 0.55 * np.clip(normal @ LIGHT, 0.0, 1.0)
    rgb = colours[index] * shade[:, None]
    h, w = intrinsics.height, intrinsics.width
    depth = np.where(hit, best, 0.0).astype(np.float32)
    return Cast(
        depth=depth.reshape(h, w),
        rgb=np.clip(np.round(rgb * 255.0), 0, 255).astype(np.uint8).reshape(h, w, 3),
        index=index.reshape(h, w),
        cos_incidence=cos_inc.reshape(h, w),
    )


@dataclass(frozen=True, slots=True)
class StereoNoise:
    """A stereo depth sensor's noise, as a datasheet states it.

    The depth RMS error of a stereo camera grows with the square of the range:
    sigma(z) = z^2 * subpixel / (focal * baseline). The defaults are an Intel RealSense D415's
    (55 mm baseline, 0.08 px subpixel RMS, 1 mm depth unit; focal length of its 1280 x 720
    depth stream at its 65 deg HFOV, 1004.6 px).

    Attributes:
        baseline: Stereo baseline [m].
        subpixel: Disparity RMS error [px].
        focal: Focal length of the depth stream [px].
        depth_unit: Quantisation step of the depth [m].
        min_cos: Pixels whose ray meets the surface at a cosine below this are missing.
        rgb_sigma: RGB noise standard deviation [0-255 levels].
    """

    baseline: float = 0.055
    subpixel: float = 0.08
    focal: float = 1004.6
    depth_unit: float = 0.001
    min_cos: float = 0.12
    rgb_sigma: float = 2.0

    def sigma(self, z: npt.ArrayLike) -> FloatArray:
        """Depth RMS error [m] at depth ``z`` [m]."""
        zz = np.asarray(z, dtype=np.float64)
        return zz * zz * self.subpixel / (self.focal * self.baseline)


def observe(
    primitives: list[Primitive],
    intrinsics: Intrinsics,
    T_base_camera: npt.ArrayLike,
    rng: np.random.Generator | None = None,
    noise: StereoNoise | None = None,
    sensor: str = "synthetic",
) -> tuple[Observation, Cast]:
    """A noisy observation of ``primitives`` (noise-free when ``rng`` is None) and the cast.

    Args:
        primitives: The scene's solids, in the base frame.
        intrinsics: The camera's intrinsics.
        T_base_camera: 4 x 4 pose of the optical frame in the base frame [m].
        rng: The noise's generator; None for a perfect image.
        noise: The noise model (a D415's by default).
        sensor: The sensor's name in the observation.
    """
    c = cast(primitives, intrinsics, T_base_camera)
    depth = c.depth.astype(np.float64)
    rgb = c.rgb
    if rng is not None:
        nm = noise or StereoNoise()
        hit = depth > 0.0
        depth = depth + rng.standard_normal(depth.shape) * nm.sigma(depth)
        depth = np.round(depth / nm.depth_unit) * nm.depth_unit
        depth[~hit | (c.cos_incidence < nm.min_cos)] = 0.0
        noisy = rgb.astype(np.float64) + rng.standard_normal(rgb.shape) * nm.rgb_sigma
        rgb = np.clip(np.round(noisy), 0, 255).astype(np.uint8)
    obs = Observation(
        sensor=sensor,
        rgb=rgb,
        depth=depth.astype(np.float32),
        intrinsics=intrinsics,
        T_base_camera=np.asarray(T_base_camera, dtype=np.float64),
    )
    return obs, c


def look_at(position: npt.ArrayLike, target: npt.ArrayLike) -> FloatArray:
    """The optical frame (x right, y down, z forward) at ``position`` looking at ``target``
    [m], image up along the base frame's z."""
    p = np.asarray(position, dtype=np.float64)
    fwd = np.asarray(target, dtype=np.float64) - p
    fwd /= np.linalg.norm(fwd)
    right = np.cross(fwd, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    down = np.cross(fwd, right)
    T = np.eye(4)
    T[:3, :3] = np.column_stack((right, down, fwd))
    T[:3, 3] = p
    return T
