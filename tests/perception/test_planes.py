"""RANSAC planes and the shelf's faces taken out of a bay's cloud, within their limits."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kr210_sim.perception.camera import Intrinsics
from kr210_sim.perception.cloud import bay_cloud
from kr210_sim.perception.planes import FACES, ransac_plane, remove_shelf
from kr210_sim.perception.synthetic import observe
from kr210_sim.perception.synthetic_bay import (
    DEFAULT_BAY,
    DEFAULT_KINDS,
    clutter,
    fixed_camera,
    shelf_primitives,
)

K = Intrinsics.from_fovy(640, 480, 50.0)


def test_ransac_finds_the_plane_among_outliers() -> None:
    """40 % outliers, 2 mm noise: the plane's coefficients within 1 % and 1 mm."""
    rng = np.random.default_rng(7)
    X = rng.uniform(-0.3, 0.3, (1000, 2))
    y = 0.05 * X[:, 0] - 0.02 * X[:, 1] + 0.1 + rng.normal(0.0, 0.002, 1000)
    y[:400] += rng.uniform(0.02, 0.3, 400)
    (a, b, c), inl = ransac_plane(X, y, 0.006, rng)
    assert (a, b, c) == pytest.approx((0.05, -0.02, 0.1), abs=1e-3)
    assert not inl[:400][y[:400] - (0.05 * X[:400, 0] - 0.02 * X[:400, 1] + 0.1) > 0.01].any()
    assert inl[400:].mean() > 0.95


def test_ransac_limits_refuse_a_steeper_plane() -> None:
    """Only a 45 deg plane in the data: no hypothesis is within a 6 deg slope."""
    rng = np.random.default_rng(1)
    X = rng.uniform(-0.2, 0.2, (300, 2))
    (a, _, _), inl = ransac_plane(X, X[:, 0], 0.005, rng, max_slope=math.tan(math.radians(6)))
    assert math.isnan(a) and not inl.any()


def _scene_cloud(T: np.ndarray, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    prims, _ = clutter(rng, DEFAULT_BAY, DEFAULT_KINDS[0], list(DEFAULT_KINDS[1:3]))
    obs, _ = observe(shelf_primitives(DEFAULT_BAY) + prims, K, T, rng)
    return bay_cloud(obs, DEFAULT_BAY, 0.03, 0.006, below=0.1)


def test_the_shelf_goes_and_the_objects_stay() -> None:
    """Of the noisy fixed look: the board, back panel and left post are found at the layout's
    place; what is left lies inside the bay above the board, at least 6 mm off the faces."""
    local, _ = _scene_cloud(fixed_camera(DEFAULT_BAY))
    out = remove_shelf(local, DEFAULT_BAY.half, np.random.default_rng(0))
    assert out.problems == ()
    found = {p.face: p for p in out.planes}
    assert [f for f, _, _ in FACES] == [p.face for p in out.planes]
    for face in ("board", "back panel", "left post"):
        assert found[face].found, found[face]
        assert abs(found[face].shift) < 0.005 and found[face].tilt_deg < 3.0
    kept = local[out.keep]
    hx, _, hz = DEFAULT_BAY.half
    assert len(kept) > 500
    assert kept[:, 2].min() > -hz + 0.006
    assert kept[:, 0].max() < hx - 0.006
    assert 0.5 * len(local) > len(kept)


def test_a_board_off_the_layout_is_a_wrong_extrinsic() -> None:
    """The camera's pose told 8 cm too low: the board is not where the layout puts it."""
    T = fixed_camera(DEFAULT_BAY)
    local, _ = _scene_cloud(T)
    local = local + np.array([0.0, 0.0, -0.08])
    out = remove_shelf(local, DEFAULT_BAY.half, np.random.default_rng(0))
    assert len(out.problems) == 1
    assert "extrinsic" in out.problems[0] and "board" in out.problems[0]


def test_a_board_slightly_off_is_found_and_flagged() -> None:
    """3 cm off: found (within the plane's limit), but beyond the board's 2.5 cm."""
    local, _ = _scene_cloud(fixed_camera(DEFAULT_BAY))
    out = remove_shelf(
        local + np.array([0.0, 0.0, 0.03]), DEFAULT_BAY.half, np.random.default_rng(0)
    )
    assert out.planes[0].found and out.planes[0].shift == pytest.approx(-0.03, abs=0.005)
    assert "+" not in out.problems[0] and "-3" in out.problems[0]
