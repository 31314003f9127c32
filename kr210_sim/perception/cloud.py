"""A bay of the shelf as a box, and the cloud cropped to it and thinned on a voxel grid.

A bay's box is shelf-aligned: its x axis points from the open front into the shelf, z up, and it
holds the bay's inside: from the top of its board to the underside of the board above, between
the posts, from the open front to the back wall. The caller passes it as numbers (from the
cell's layout); this room knows nothing of cell files.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from kr210_sim.perception.camera import Intrinsics, Observation, backproject, project

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class BayBox:
    """The inside of one bay.

    Attributes:
        centre: The box's centre in the base frame [m].
        yaw: The box's rotation about z [rad] (0: x into the shelf along the base frame's x).
        half: Half extents (depth into the shelf, width, height) [m].
    """

    centre: tuple[float, float, float]
    yaw: float
    half: tuple[float, float, float]

    def __post_init__(self) -> None:
        if not all(h > 0.0 for h in self.half):
            raise ValueError(f"a bay's half extents must be positive, got {self.half}")
        if not all(math.isfinite(c) for c in (*self.centre, self.yaw)):
            raise ValueError("a bay's centre and yaw must be finite")

    @property
    def rotation(self) -> FloatArray:
        """The box frame's rotation in the base frame (columns: x in, y, z up)."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    def to_local(self, points: npt.ArrayLike) -> FloatArray:
        """Base-frame points [m] in the box frame [m] (origin at the centre)."""
        p = np.asarray(points, dtype=np.float64)
        return (p - np.asarray(self.centre)) @ self.rotation

    def to_base(self, local: npt.ArrayLike) -> FloatArray:
        """Box-frame points [m] in the base frame [m]."""
        p = np.asarray(local, dtype=np.float64)
        return p @ self.rotation.T + np.asarray(self.centre)

    def floor_z(self) -> float:
        """z of the bay's board top in the base frame [m]."""
        return self.centre[2] - self.half[2]


def crop(
    points: FloatArray,
    colours: npt.NDArray[np.uint8],
    box: BayBox,
    margin: float = 0.0,
    below: float = 0.0,
) -> tuple[FloatArray, npt.NDArray[np.uint8]]:
    """The points inside ``box`` grown by ``margin`` [m] on every side (and by ``below`` [m]
    more downwards), in the box frame.

    Args:
        points: (N, 3) base-frame points [m].
        colours: (N, 3) their colours.
        box: The bay.
        margin: How far outside the box a point may lie and be kept [m] (negative: shrink).
        below: How much farther below the box's floor a point may lie and be kept [m].

    Returns:
        The kept points in the box frame [m] and their colours.
    """
    local = box.to_local(points)
    lim = np.asarray(box.half) + margin
    inside = np.all(np.abs(local[:, :2]) <= lim[:2], axis=1)
    inside &= (local[:, 2] <= lim[2]) & (local[:, 2] >= -lim[2] - below)
    return local[inside], colours[inside]


def voxel_downsample(
    points: FloatArray, colours: npt.NDArray[np.uint8], voxel: float
) -> tuple[FloatArray, npt.NDArray[np.uint8]]:
    """One point per occupied voxel: the mean of the points in it, and their mean colour.

    Args:
        points: (N, 3) points [m].
        colours: (N, 3) colours.
        voxel: Edge of the grid's cubes [m] (the grid's origin is the frame's).

    Returns:
        The (M, 3) means [m] and (M, 3) uint8 colours, ordered by voxel index.
    """
    if voxel <= 0.0:
        raise ValueError(f"voxel size must be positive, got {voxel}")
    if len(points) == 0:
        return points.reshape(0, 3), colours.reshape(0, 3)
    keys = np.floor(points / voxel).astype(np.int64)
    keys -= keys.min(axis=0)
    span = keys.max(axis=0) + 1
    flat = (keys[:, 0] * span[1] + keys[:, 1]) * span[2] + keys[:, 2]
    _, inverse, counts = np.unique(flat, return_inverse=True, return_counts=True)
    n = len(counts)
    sums = np.column_stack([np.bincount(inverse, points[:, k], n) for k in range(3)])
    csum = np.column_stack([np.bincount(inverse, colours[:, k], n) for k in range(3)])
    means = sums / counts[:, None]
    cmeans = np.clip(np.round(csum / counts[:, None]), 0, 255).astype(np.uint8)
    return means, cmeans


def _roi(
    obs: Observation, box: BayBox, margin: float, below: float
) -> tuple[int, int, int, int, float] | None:
    """The pixel rectangle (u0, u1, v0, v1) holding the box's image, and the depth of the
    box's centre [m] (of the image's nearer pixels when the box wraps the camera); None when
    the box is not in front of the camera or outside the image."""
    h = np.asarray(box.half) + margin
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    corners = signs * h
    corners[corners[:, 2] < 0.0, 2] -= below
    corners = box.to_base(corners)
    T = np.asarray(obs.T_base_camera, dtype=np.float64)
    cam = (corners - T[:3, 3]) @ T[:3, :3]
    z = cam[:, 2]
    k = obs.intrinsics
    if np.all(z <= 0.0):
        return None
    if np.any(z <= 0.0):  # the box wraps the camera: the whole image, at its nearer depths
        d = obs.depth[::8, ::8]
        d = d[d > 0.0]
        return 0, k.width, 0, k.height, float(np.percentile(d, 10.0)) if d.size else 0.0
    uv = project(cam, k)
    u0 = int(np.clip(np.floor(uv[:, 0].min()), 0, k.width))
    u1 = int(np.clip(np.ceil(uv[:, 0].max()) + 1, 0, k.width))
    v0 = int(np.clip(np.floor(uv[:, 1].min()), 0, k.height))
    v1 = int(np.clip(np.ceil(uv[:, 1].max()) + 1, 0, k.height))
    if u1 <= u0 or v1 <= v0:
        return None
    centre_z = float((np.asarray(box.centre) - T[:3, 3]) @ T[:3, 2])
    return u0, u1, v0, v1, centre_z


def bay_cloud(
    obs: Observation, box: BayBox, margin: float, voxel: float, below: float = 0.0
) -> tuple[FloatArray, npt.NDArray[np.uint8]]:
    """The observation's points inside the bay (grown by ``margin`` [m]) in the box frame.

    Only the pixels of the rectangle that holds the box's image are back-projected, every
    ``s``-th row and column where a voxel at the box's near depth spans ``s - 1/2`` pixels or
    more (a close look, or a far look at a fine voxel), so a look costs what the bay's points
    cost, not the whole image's: a pixel stride about the voxel, which thins the cloud to that
    voxel in any case.

    Args:
        obs: The look.
        box: The bay.
        margin: How far outside the box a point may lie and be kept [m].
        voxel: The voxel the cloud is thinned to afterwards [m] (sets the stride).
        below: How much farther below the box's floor a point may lie and be kept [m].

    Returns:
        The (N, 3) points [m] in the box frame and their colours.
    """
    roi = _roi(obs, box, margin, below)
    if roi is None:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.uint8)
    u0, u1, v0, v1, z_near = roi
    k = obs.intrinsics
    step = max(1, round(voxel * k.fx / max(z_near, 1e-6))) if z_near > 0.0 else 1
    depth = obs.depth[v0:v1:step, u0:u1:step]
    sub = Intrinsics(
        width=depth.shape[1],
        height=depth.shape[0],
        fx=k.fx / step,
        fy=k.fy / step,
        cx=(k.cx - u0) / step,
        cy=(k.cy - v0) / step,
    )
    pts, valid = backproject(depth, sub)
    T = np.asarray(obs.T_base_camera, dtype=np.float64)
    base = pts @ T[:3, :3].T + T[:3, 3]
    colours = obs.rgb[v0:v1:step, u0:u1:step][valid]
    return crop(base, colours, box, margin, below)
