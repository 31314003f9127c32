"""The depth camera's noise model: its statistics match its parameters (the datasheet's RMS at
1 m and 2 m, the disparity step, dropouts at grazing angles and on dark and saturated surfaces,
flying pixels at edges, RGB noise), it is seeded, and switched off it leaves images as rendered."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from kr210_sim.perception.camera import Intrinsics
from kr210_sim.sensors.noise import MODELS, apply_noise, incidence_deg

K = Intrinsics.from_fovy(320, 240, 50.0)
GREY = np.full((240, 320, 3), 120, dtype=np.uint8)


def _plane(z: float) -> np.ndarray:
    return np.full((240, 320), z, dtype=np.float32)


def _tilted(distance: float, tilt_deg: float, intr: Intrinsics) -> np.ndarray:
    """Depth of a plane ``distance`` ahead turned ``tilt_deg`` about the image's vertical."""
    a = math.radians(tilt_deg)
    u = (np.arange(intr.width) - intr.cx) / intr.fx
    z = distance * math.cos(a) / (math.cos(a) - math.sin(a) * u)
    return np.broadcast_to(z, (intr.height, intr.width)).astype(np.float32).copy()


def test_the_datasheet_figures() -> None:
    d415, d435 = MODELS["d415"], MODELS["d435"]
    # RMS = z^2 * 0.08 / (f b): D415 f = 640 / tan(32.5 deg), b = 55 mm
    assert d415.focal_px == pytest.approx(1004.6, abs=0.1)
    assert float(d415.depth_rms(1.0)) == pytest.approx(1.448e-3, rel=1e-3)
    assert float(d415.depth_rms(2.0)) == pytest.approx(5.79e-3, rel=1e-3)
    assert float(d435.depth_rms(2.0)) == pytest.approx(4 * 0.08 / (640.0 * 0.05), rel=1e-9)
    assert float(d415.depth_step(1.0)) == pytest.approx(1.0 / (32 * 1004.6 * 0.055), rel=1e-3)


@pytest.mark.parametrize("name", ["d415", "d435"])
@pytest.mark.parametrize("z", [1.0, 2.0])
def test_depth_noise_std_grows_with_range_as_the_model_says(name: str, z: float) -> None:
    model = MODELS[name]
    _, depth = apply_noise(GREY, _plane(z), K, model, np.random.default_rng(7))
    err = depth[depth > 0].astype(np.float64) - z
    assert len(err) > 0.99 * depth.size  # a frontal grey plane loses nothing
    assert err.std() == pytest.approx(float(model.total_rms(z)), rel=0.10)
    assert abs(err.mean()) < 0.1 * float(model.total_rms(z))


def test_quantisation_is_the_disparity_step() -> None:
    model = dataclasses.replace(MODELS["d415"], subpixel_rms=0.0, depth_unit=1e-9)
    ramp = np.broadcast_to(np.linspace(1.9, 2.1, 320, dtype=np.float32), (240, 320)).copy()
    _, depth = apply_noise(GREY, ramp, K, model, np.random.default_rng(0))
    levels = np.unique(depth[depth > 0].astype(np.float64))
    steps = np.diff(levels)
    mid = levels[:-1] + steps / 2
    assert np.allclose(steps, model.depth_step(mid), rtol=0.01)
    assert np.abs(depth - ramp).max() <= float(model.depth_step(2.1)) / 2 + 1e-6
    # and the 1 mm unit of the depth image
    unit = dataclasses.replace(MODELS["d415"], subpixel_rms=0.0)
    _, depth = apply_noise(GREY, ramp, K, unit, np.random.default_rng(0))
    assert np.allclose(depth * 1000.0, np.round(depth * 1000.0), atol=1e-3)


def test_incidence_angles_of_a_tilted_plane() -> None:
    narrow = Intrinsics.from_fovy(320, 240, 10.0)
    z = _tilted(1.5, 60.0, narrow)
    inc = incidence_deg(z, narrow)
    u = (np.arange(320) - narrow.cx) / narrow.fx
    v = (np.arange(240) - narrow.cy) / narrow.fy
    rays = np.stack(np.broadcast_arrays(u[None, :], v[:, None], np.ones((240, 320))), axis=-1)
    n = np.array([-math.sin(math.radians(60.0)), 0.0, math.cos(math.radians(60.0))])
    expected = np.degrees(np.arccos(np.abs(rays @ n) / np.linalg.norm(rays, axis=-1)))
    inner = (slice(1, -1), slice(1, -1))
    assert np.nanmax(np.abs(inc[inner] - expected[inner])) < 0.05


@pytest.mark.parametrize("tilt", [65.0, 74.0, 77.5, 82.0])
def test_dropout_at_grazing_incidence_matches_the_model(tilt: float) -> None:
    model = MODELS["d415"]
    narrow = Intrinsics.from_fovy(320, 240, 6.0)
    z = _tilted(1.0, tilt, narrow)
    _, depth = apply_noise(GREY[:, :, :], z, narrow, model, np.random.default_rng(3))
    inner = (slice(1, -1), slice(2, -2))
    expected = model.grazing_dropout(incidence_deg(z, narrow))[inner].mean()
    missing = (depth[inner] == 0).mean()
    assert missing == pytest.approx(expected, abs=0.01)
    if tilt < model.grazing_start_deg - 4:
        assert missing == 0.0


def test_dark_and_saturated_surfaces_lose_pixels_at_their_rates() -> None:
    model = MODELS["d415"]
    for value, share in ((0, model.dark_dropout), (255, model.saturated_dropout), (120, 0.0)):
        rgb = np.full((240, 320, 3), value, dtype=np.uint8)
        _, depth = apply_noise(rgb, _plane(1.0), K, model, np.random.default_rng(1))
        assert (depth == 0).mean() == pytest.approx(share, abs=0.01)


def test_flying_pixels_lie_between_the_two_sides_of_an_edge() -> None:
    model = dataclasses.replace(MODELS["d415"], subpixel_rms=0.0)
    z = _plane(1.0)
    z[:, 160:] = 2.0
    _, depth = apply_noise(GREY, z, K, model, np.random.default_rng(5))
    between = (depth > 1.01) & (depth < 1.99)
    edge = np.zeros_like(between)
    edge[:, 159:161] = True
    assert not between[~edge].any()
    assert between[edge].mean() == pytest.approx(model.flying_share, abs=0.05)


def test_rgb_noise_is_read_plus_shot_noise() -> None:
    model = MODELS["d435"]
    for value in (20, 100, 200):
        rgb = np.full((240, 320, 3), value, dtype=np.uint8)
        out, _ = apply_noise(rgb, _plane(1.0), K, model, np.random.default_rng(2))
        sigma = math.sqrt(model.rgb_read**2 + model.rgb_gain * value)
        assert out.astype(np.float64).std() == pytest.approx(sigma, rel=0.10)
        assert abs(out.astype(np.float64).mean() - value) < 0.1


def test_the_noise_is_seeded() -> None:
    model = MODELS["d415"]
    a = apply_noise(GREY, _plane(1.3), K, model, np.random.default_rng(11))
    b = apply_noise(GREY, _plane(1.3), K, model, np.random.default_rng(11))
    c = apply_noise(GREY, _plane(1.3), K, model, np.random.default_rng(12))
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    assert not np.array_equal(a[1], c[1])


def test_nothing_seen_stays_missing() -> None:
    _, depth = apply_noise(GREY, np.zeros((240, 320)), K, MODELS["d415"], np.random.default_rng(0))
    assert not depth.any()
