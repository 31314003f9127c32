"""The pinhole camera: intrinsics from MuJoCo's fovy, back-projection round trips, frames."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kr210_sim.perception.camera import (
    Intrinsics,
    Observation,
    backproject,
    optical_from_mujoco,
    project,
    ray_to_axis_depth,
)


def test_intrinsics_from_fovy_golden() -> None:
    """640 x 480 at fovy 45 deg: f = 240 / tan(22.5 deg) = 579.41 px, centre (319.5, 239.5)."""
    k = Intrinsics.from_fovy(640, 480, 45.0)
    assert k.fx == pytest.approx(579.4112549695428, rel=1e-12)
    assert (k.cx, k.cy) == (319.5, 239.5)
    assert k.fovy_deg == pytest.approx(45.0, abs=1e-12)
    assert k.fovx_deg == pytest.approx(2 * math.degrees(math.atan(320 / k.fx)))
    np.testing.assert_array_equal(k.K[2], [0.0, 0.0, 1.0])


@pytest.mark.parametrize("bad", [0.0, 180.0, -5.0])
def test_fovy_out_of_range_is_refused(bad: float) -> None:
    with pytest.raises(ValueError, match="fovy must be in"):
        Intrinsics.from_fovy(64, 48, bad)


def test_point_pixel_point_round_trip() -> None:
    """Random points in front of the camera -> pixels -> depth image -> the same points."""
    rng = np.random.default_rng(7)
    k = Intrinsics.from_fovy(320, 240, 58.0)
    u = rng.integers(0, k.width, 500)
    v = rng.integers(0, k.height, 500)
    flat = np.unique(v * k.width + u)
    v, u = np.divmod(flat, k.width)
    z = rng.uniform(0.3, 4.0, flat.size)
    pts = np.column_stack(((u - k.cx) / k.fx * z, (v - k.cy) / k.fy * z, z))
    np.testing.assert_allclose(project(pts, k), np.column_stack((u, v)), atol=1e-9)
    depth = np.zeros((k.height, k.width), np.float32)
    depth[v, u] = z
    back, valid = backproject(depth, k)
    assert valid.sum() == flat.size
    np.testing.assert_allclose(back, pts, atol=1e-6 * 4.0)


def test_points_behind_the_camera_have_no_pixel() -> None:
    k = Intrinsics.from_fovy(64, 48, 60.0)
    assert np.isnan(project([[0.0, 0.0, -1.0]], k)).all()


def test_ray_depth_is_longer_than_axis_depth_off_centre() -> None:
    """At the principal point the two agree; at pixel (u, v) the ray is longer by
    sqrt(1 + x^2 + y^2) of its normalised coordinates."""
    k = Intrinsics.from_fovy(5, 5, 90.0)  # f = 2.5 px, centre (2, 2)
    axis = ray_to_axis_depth(np.full((5, 5), 2.0), k)
    assert axis[2, 2] == pytest.approx(2.0)
    assert axis[0, 0] == pytest.approx(2.0 / math.sqrt(1 + 2 * (2 / 2.5) ** 2))


def test_optical_frame_looks_along_mujoco_minus_z() -> None:
    """A MuJoCo camera with the identity frame looks down -z, image up +y: the optical frame's
    z is world -z and its y (image down) is world -y."""
    T = optical_from_mujoco([1.0, 2.0, 3.0], np.eye(3))
    np.testing.assert_allclose(T[:3, 2], [0.0, 0.0, -1.0])
    np.testing.assert_allclose(T[:3, 1], [0.0, -1.0, 0.0])
    np.testing.assert_allclose(T[:3, 3], [1.0, 2.0, 3.0])


def test_observation_cloud_in_base_frame_and_shape_checks() -> None:
    k = Intrinsics.from_fovy(4, 3, 60.0)
    depth = np.zeros((3, 4), np.float32)
    depth[1, 2] = 2.0
    rgb = np.zeros((3, 4, 3), np.uint8)
    rgb[1, 2] = (10, 20, 30)
    T = optical_from_mujoco([0.0, 0.0, 5.0], np.eye(3))  # looking straight down from 5 m
    pts, cols = Observation("top", rgb, depth, k, T).cloud()
    assert pts.shape == (1, 3) and pts[0, 2] == pytest.approx(3.0)
    np.testing.assert_array_equal(cols, [[10, 20, 30]])
    with pytest.raises(ValueError, match="depth must be"):
        Observation("top", rgb, depth[:2], k, T)
