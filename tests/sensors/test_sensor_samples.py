"""Rendered samples and the truth: seeded, labelled pixel by pixel, and every labelled pixel's
point inside the object the truth says is there (pose and size cross-checked by the render)."""

from __future__ import annotations

import numpy as np
import pytest

from kr210_sim.cell.load import model_at
from kr210_sim.sensors.samples import render_samples
from kr210_sim.sensors.truth import TruthObject
from kr210_sim.util.paths import SCENES_DIR

pytestmark = pytest.mark.render
CLUTTERED = SCENES_DIR / "cells" / "cluttered.toml"


def _inside(obj: TruthObject, points: np.ndarray, tol: float) -> np.ndarray:
    """Whether each point [m] lies within ``tol`` [m] of the object's volume."""
    local = (points - obj.position) @ obj.R
    if obj.shape == "sphere":
        return np.linalg.norm(local, axis=1) <= obj.size[0] + tol
    if obj.shape == "cylinder":
        r = np.linalg.norm(local[:, :2], axis=1)
        return (r <= obj.size[0] + tol) & (np.abs(local[:, 2]) <= obj.size[1] / 2 + tol)
    half = np.array(obj.size) / 2 + tol
    return np.all(np.abs(local) <= half, axis=1)


def test_samples_are_seeded_labelled_and_true_to_the_render() -> None:
    model = model_at(CLUTTERED)
    before = model.geom_size.copy(), model.geom_rgba.copy()
    samples = list(render_samples(model, 3, seed=4, noise=False))
    assert np.array_equal(model.geom_size, before[0]) and np.array_equal(model.geom_rgba, before[1])
    assert [s.index for s in samples] == [0, 1, 2]
    assert {s.observation.sensor for s in samples} == {"shelf_rgbd"}
    kinds = {"target", "red_can", "white_bottle", "green_box", "black_box", "yellow_ball"}
    for s in samples:
        labels = {o.label for o in s.truth}
        assert labels <= kinds and len(s.truth) >= 9  # at least one distractor a bay
        target = s.truth[s.target]
        assert target.is_target and target.label in ("target", "red_can")
        # no distractor of the target's kind stands on the shelf
        assert sum(o.label == target.label for o in s.truth) == 1
        obs = s.observation
        pts, _ = obs.cloud()
        valid = obs.depth > 0
        lab = s.labels[valid]
        seen = 0
        for j, obj in enumerate(s.truth):
            mine = pts[lab == j]
            if len(mine) < 30:
                continue
            seen += 1
            assert _inside(obj, mine, 0.004).mean() > 0.995, (obj.label, obj.shape)
        assert seen >= 6
        # pixels of nothing on the shelf are not inside any object
        other = pts[lab == -1]
        for obj in s.truth:
            assert _inside(obj, other, -0.004).mean() < 0.001
    again = next(render_samples(model, 1, seed=4, noise=False))
    assert np.array_equal(again.observation.rgb, samples[0].observation.rgb)
    noisy = next(render_samples(model, 1, seed=4))
    assert not np.array_equal(noisy.observation.depth, samples[0].observation.depth)
    assert [o.label for o in noisy.truth] == [o.label for o in samples[0].truth]


def test_the_wrist_camera_looks_from_the_standoff_and_sees_the_target_large() -> None:
    model = model_at(CLUTTERED)
    fixed, wrist = list(render_samples(model, 1, seed=2, sensors=("shelf_rgbd", "gripper")))
    assert (fixed.observation.sensor, wrist.observation.sensor) == ("shelf_rgbd", "gripper")
    near = (wrist.labels == wrist.target).sum()
    assert near > 3 * (fixed.labels == fixed.target).sum() and near > 2000
    obs = wrist.observation
    target = wrist.truth[wrist.target]
    pts, _ = obs.cloud()
    mine = pts[wrist.labels[obs.depth > 0] == wrist.target]
    # noisy (a D435 at about 0.7 m: 3 mm RMS), yet on the target
    assert _inside(target, mine, 0.015).mean() > 0.97
    # the camera is in front of the target, above it, looking at it
    T = obs.T_base_camera
    to_target = target.position - T[:3, 3]
    assert 0.5 < np.linalg.norm(to_target) < 1.0
    assert to_target @ T[:3, 2] / np.linalg.norm(to_target) > 0.9
