"""The bay's box, the crop, the voxel grid and the bay's cloud from a look."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kr210_sim.perception.camera import Intrinsics
from kr210_sim.perception.cloud import BayBox, bay_cloud, crop, voxel_downsample
from kr210_sim.perception.synthetic import observe
from kr210_sim.perception.synthetic_bay import (
    DEFAULT_BAY,
    fixed_camera,
    shelf_primitives,
    wrist_camera,
)

K = Intrinsics.from_fovy(640, 480, 50.0)


def test_box_frame_round_trip_and_yaw() -> None:
    """A turned box: base -> local -> base is the identity; the box's x is its yaw's heading."""
    box = BayBox((1.0, 2.0, 0.5), math.radians(30.0), (0.2, 0.4, 0.3))
    rng = np.random.default_rng(0)
    p = rng.uniform(-3, 3, (1000, 3))
    np.testing.assert_allclose(box.to_base(box.to_local(p)), p, atol=1e-12)
    ahead = box.to_base([[1.0, 0.0, 0.0]])[0]
    np.testing.assert_allclose(ahead, [1.0 + math.cos(math.pi / 6), 2.0 + 0.5, 0.5], atol=1e-12)
    assert box.floor_z() == pytest.approx(0.2)


def test_bad_box_is_refused() -> None:
    with pytest.raises(ValueError, match="half extents must be positive"):
        BayBox((0.0, 0.0, 0.0), 0.0, (0.1, -0.1, 0.1))


def test_crop_keeps_exactly_the_inside() -> None:
    box = BayBox((0.0, 0.0, 0.0), 0.0, (0.5, 0.5, 0.5))
    pts = np.array([[0.49, 0.0, 0.0], [0.51, 0.0, 0.0], [0.0, -0.6, 0.0], [0.0, 0.0, 0.0]])
    cols = np.arange(12, dtype=np.uint8).reshape(4, 3)
    kept, kc = crop(pts, cols, box)
    np.testing.assert_array_equal(kept, pts[[0, 3]])
    np.testing.assert_array_equal(kc, cols[[0, 3]])
    assert len(crop(pts, cols, box, margin=0.02)[0]) == 3


def test_voxel_downsample_means_per_cube() -> None:
    """Two points in one cube average; a point alone stays; colours average and round."""
    pts = np.array([[0.001, 0.001, 0.001], [0.003, 0.009, 0.005], [0.021, 0.0, 0.0]])
    cols = np.array([[10, 20, 30], [11, 20, 31], [200, 0, 0]], dtype=np.uint8)
    out, oc = voxel_downsample(pts, cols, 0.01)
    np.testing.assert_allclose(out, [[0.002, 0.005, 0.003], [0.021, 0.0, 0.0]], atol=1e-15)
    np.testing.assert_array_equal(oc, [[10, 20, 30], [200, 0, 0]])  # 10.5 rounds to even
    with pytest.raises(ValueError, match="voxel size"):
        voxel_downsample(pts, cols, 0.0)


def test_voxel_downsample_thins_to_one_point_per_cube() -> None:
    rng = np.random.default_rng(3)
    pts = rng.uniform(0.0, 0.1, (20000, 3))
    out, _ = voxel_downsample(pts, np.zeros((20000, 3), dtype=np.uint8), 0.01)
    keys = np.floor(out / 0.01)
    assert len(out) == 1000 == len(np.unique(keys, axis=0))


@pytest.mark.parametrize("near", [False, True])
def test_bay_cloud_is_the_observations_cloud_cropped(near: bool) -> None:
    """Cross-check: the bay's pixels only (and every s-th of them near) give the points of the
    whole image's cloud cropped to the box."""
    prims = shelf_primitives(DEFAULT_BAY)
    T = wrist_camera(DEFAULT_BAY, DEFAULT_BAY.centre) if near else fixed_camera(DEFAULT_BAY)
    obs, _ = observe(prims, K, T)
    full, _ = crop(*obs.cloud(), DEFAULT_BAY, 0.03)
    part, pc = bay_cloud(obs, DEFAULT_BAY, 0.03, voxel=0.006)
    if near:
        assert len(part) < len(full) / 2  # strided
    else:
        assert len(part) == len(full)
    rows = {tuple(np.round(p, 9)) for p in full}
    assert all(tuple(np.round(p, 9)) in rows for p in part)
    assert len(pc) == len(part)


def test_bay_cloud_of_a_camera_looking_away_is_empty() -> None:
    T = fixed_camera(DEFAULT_BAY)
    T[:3, :3] = T[:3, :3] @ np.diag([-1.0, 1.0, -1.0])  # turned round
    obs, _ = observe(shelf_primitives(DEFAULT_BAY), K, T)
    pts, cols = bay_cloud(obs, DEFAULT_BAY, 0.03, 0.006)
    assert pts.shape == (0, 3) and cols.shape == (0, 3)
