"""The pinhole camera: intrinsics, back-projection of a depth image, and one observation.

Conventions (those of OpenCV and ROS's optical frames): the camera frame has x to the right of
the image, y down, z forward along the optical axis; pixel (u, v) has u along the columns and v
along the rows, (0, 0) the *centre* of the top-left pixel. A depth image holds, per pixel, the
distance [m] from the camera to the surface *along the optical axis* (the z coordinate in the
camera frame, the distance to the image plane), not along the ray; 0 marks a missing pixel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class Intrinsics:
    """A pinhole camera's intrinsics, without distortion.

    Attributes:
        width: Image width [px].
        height: Image height [px].
        fx: Focal length along the columns [px].
        fy: Focal length along the rows [px].
        cx: Principal point's column [px] (pixel centres at integers).
        cy: Principal point's row [px].
    """

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float

    def __post_init__(self) -> None:
        if self.width < 1 or self.height < 1:
            raise ValueError(
                f"image size must be at least 1 x 1 px, got {self.width} x {self.height}"
            )
        if not (self.fx > 0 and self.fy > 0):
            raise ValueError(f"focal lengths must be positive, got fx={self.fx}, fy={self.fy}")

    @classmethod
    def from_fovy(cls, width: int, height: int, fovy_deg: float) -> Intrinsics:
        """The intrinsics of a camera as MuJoCo renders it: square pixels, the principal point at
        the image centre, and ``fovy`` the full vertical field of view.

        Args:
            width: Image width [px].
            height: Image height [px].
            fovy_deg: Full vertical field of view [deg], in (0, 180).
        """
        if not 0.0 < fovy_deg < 180.0:
            raise ValueError(f"fovy must be in (0, 180) deg, got {fovy_deg}")
        f = 0.5 * height / math.tan(math.radians(fovy_deg) / 2.0)
        return cls(width, height, f, f, (width - 1) / 2.0, (height - 1) / 2.0)

    @property
    def K(self) -> FloatArray:
        """The 3 x 3 camera matrix."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def fovy_deg(self) -> float:
        """Full vertical field of view [deg]."""
        return math.degrees(2.0 * math.atan(0.5 * self.height / self.fy))

    @property
    def fovx_deg(self) -> float:
        """Full horizontal field of view [deg]."""
        return math.degrees(2.0 * math.atan(0.5 * self.width / self.fx))


def backproject(
    depth: npt.NDArray[np.floating], intrinsics: Intrinsics
) -> tuple[FloatArray, npt.NDArray[np.bool_]]:
    """Every valid pixel of a depth image as a point in the camera frame.

    Args:
        depth: (H, W) distances along the optical axis [m]; 0, negative or non-finite = missing.
        intrinsics: The camera's intrinsics (its size must match ``depth``).

    Returns:
        The (N, 3) points [m] in the camera frame, row-major over the valid pixels, and the
        (H, W) mask of those pixels.
    """
    h, w = depth.shape
    if (w, h) != (intrinsics.width, intrinsics.height):
        raise ValueError(
            f"depth image is {w} x {h} px but the intrinsics are for "
            f"{intrinsics.width} x {intrinsics.height}"
        )
    z = np.asarray(depth, dtype=np.float64)
    valid = np.isfinite(z) & (z > 0.0)
    v, u = np.nonzero(valid)
    zs = z[v, u]
    x = (u - intrinsics.cx) / intrinsics.fx * zs
    y = (v - intrinsics.cy) / intrinsics.fy * zs
    return np.column_stack((x, y, zs)), valid


def project(points: npt.ArrayLike, intrinsics: Intrinsics) -> FloatArray:
    """Camera-frame points to pixel coordinates (u, v) [px]; points at z <= 0 give NaN."""
    p = np.atleast_2d(np.asarray(points, dtype=np.float64))
    z = p[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        u = intrinsics.fx * p[:, 0] / z + intrinsics.cx
        v = intrinsics.fy * p[:, 1] / z + intrinsics.cy
    out = np.column_stack((u, v))
    out[z <= 0.0] = np.nan
    return out


def ray_to_axis_depth(ray_depth: npt.ArrayLike, intrinsics: Intrinsics) -> FloatArray:
    """Distances along each pixel's ray [m] to distances along the optical axis [m].

    A real sensor's range (a lidar's, a time-of-flight camera's raw output) is along the ray;
    a depth image is along the axis: the two differ by the ray's cosine to the axis, 1 at the
    principal point and about 0.87 at the corner of a 60 deg-wide image.
    """
    r = np.asarray(ray_depth, dtype=np.float64)
    h, w = r.shape
    u = (np.arange(w) - intrinsics.cx) / intrinsics.fx
    v = (np.arange(h) - intrinsics.cy) / intrinsics.fy
    norm = np.sqrt(1.0 + u[None, :] ** 2 + v[:, None] ** 2)
    return r / norm


@dataclass(frozen=True)
class Observation:
    """One look of one sensor: what a perception function is given.

    Attributes:
        sensor: The sensor's name in the cell file.
        rgb: (H, W, 3) colour image, uint8.
        depth: (H, W) float32 distances along the optical axis [m]; 0 marks a missing pixel.
        intrinsics: The sensor's intrinsics.
        T_base_camera: 4 x 4 pose of the camera's optical frame (x right, y down, z forward)
            in the robot's base frame [m].
        time: Simulated time of the look [s].
    """

    sensor: str
    rgb: npt.NDArray[np.uint8]
    depth: npt.NDArray[np.float32]
    intrinsics: Intrinsics
    T_base_camera: FloatArray
    time: float = 0.0

    def __post_init__(self) -> None:
        h, w = self.intrinsics.height, self.intrinsics.width
        if self.rgb.shape != (h, w, 3):
            raise ValueError(f"rgb must be ({h}, {w}, 3), got {self.rgb.shape}")
        if self.depth.shape != (h, w):
            raise ValueError(f"depth must be ({h}, {w}), got {self.depth.shape}")
        if np.asarray(self.T_base_camera).shape != (4, 4):
            raise ValueError("T_base_camera must be a 4 x 4 transform")

    def cloud(self) -> tuple[FloatArray, npt.NDArray[np.uint8]]:
        """The valid pixels as points in the base frame [m] with their colours.

        Returns:
            (N, 3) points [m] in the base frame and their (N, 3) uint8 colours.
        """
        pts, valid = backproject(self.depth, self.intrinsics)
        T = np.asarray(self.T_base_camera, dtype=np.float64)
        return pts @ T[:3, :3].T + T[:3, 3], self.rgb[valid]


def optical_from_mujoco(xpos: npt.ArrayLike, xmat: npt.ArrayLike) -> FloatArray:
    """The optical frame's pose in the world from a MuJoCo camera's ``cam_xpos``/``cam_xmat``.

    A MuJoCo camera looks along its own -z with +y up in the image; the optical frame looks
    along +z with +y down: the same origin, the y and z axes turned over.
    """
    T = np.eye(4)
    T[:3, :3] = np.asarray(xmat, dtype=np.float64).reshape(3, 3) @ np.diag([1.0, -1.0, -1.0])
    T[:3, 3] = np.asarray(xpos, dtype=np.float64)
    return T
