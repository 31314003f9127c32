"""Offscreen stills (needs an OpenGL backend: EGL on headless machines)."""

from __future__ import annotations

from pathlib import Path

import imageio.v3 as iio
import mujoco
import numpy as np
import pytest

from kr210_sim.cell.load import load_model
from kr210_sim.errors import ConfigError
from kr210_sim.media.render import DRAW_BUILTINS, draw_level, make_renderer, render_frame, snapshot

pytestmark = pytest.mark.render


@pytest.mark.parametrize("camera", ["overview", "shelf", "bin", "gripper"])
def test_snapshot_each_camera(tmp_path: Path, camera: str) -> None:
    path = snapshot(tmp_path / f"{camera}.png", camera=camera, width=320, height=240)
    img = iio.imread(path)
    assert img.shape == (240, 320, 3)
    assert img.std() > 10  # not blank
    assert len(np.unique(img.reshape(-1, 3), axis=0)) > 100


def test_unknown_camera_lists_the_names(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="no camera 'nope'; cameras: overview, shelf, bin"):
        snapshot(tmp_path / "x.png", camera="nope")


def test_offscreen_buffer_grows_to_fit_a_large_frame() -> None:
    model = load_model()
    assert (model.vis.global_.offwidth, model.vis.global_.offheight) == (1920, 1088)
    renderer = make_renderer(model, 2560, 1440)
    try:
        renderer.update_scene(mujoco.MjData(model), camera="overview")
        assert renderer.render().shape == (1440, 2560, 3)
    finally:
        renderer.close()
    with pytest.raises(ConfigError, match="too large: at most 8192 px"):
        make_renderer(model, 9000, 480)


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs Linux's /proc")
def test_snapshot_into_a_folder_that_refuses_files(capsys: pytest.CaptureFixture[str]) -> None:
    """/proc takes no new files, not even from root (whom the up-front check lets through)."""
    from kr210_sim.cli import main

    assert (
        main(["snapshot", "--out", "/proc/kr210_sim.png", "--width", "160", "--height", "96"]) == 2
    )
    err = capsys.readouterr().err
    assert err.startswith("kr210_sim: error: cannot write /proc/kr210_sim.png")
    assert len(err.strip().splitlines()) == 1


def test_the_draw_level_changes_only_what_is_drawn_and_looks_the_same() -> None:
    """The video's level of detail: the floor's speckle drawn as its mean colour (0.478 grey,
    measured from the texture), coarser built-in shapes; the original model untouched, the copy
    steps exactly as it, and a frame from the overview matches the fine one within 1 % of a
    grey level on average."""
    model = load_model()
    fine_quality = (model.vis.quality.numslices, model.vis.quality.numstacks)
    draw = draw_level(model)
    floor = model.material("floor").id
    rgb = int(mujoco.mjtTextureRole.mjTEXROLE_RGB)
    assert model.mat_texid[floor, rgb] >= 0 and draw.mat_texid[floor, rgb] == -1
    assert np.allclose(draw.mat_rgba[floor], [0.4783, 0.4783, 0.4665, 1.0], atol=1e-4)
    assert np.array_equal(model.mat_rgba[floor], [1, 1, 1, 1])
    quality = draw.vis.quality
    assert (quality.numslices, quality.numstacks, quality.numquads) == DRAW_BUILTINS
    assert (model.vis.quality.numslices, model.vis.quality.numstacks) == fine_quality == (28, 16)
    ctrl = np.random.default_rng(3).uniform(-0.01, 0.01, (200, model.nu)).cumsum(axis=0)
    runs = []
    for m in (model, draw):
        data = mujoco.MjData(m)
        mujoco.mj_resetDataKeyframe(m, data, 0)
        start = data.qpos.copy()
        for u in ctrl:
            data.ctrl[:] = start[: m.nu] + u
            mujoco.mj_step(m, data)
        runs.append(data.qpos.copy())
    assert np.abs(runs[0] - start).max() > 1e-3  # it moved
    assert np.array_equal(runs[0], runs[1])
    frames = []
    for m in (model, draw):
        data = mujoco.MjData(m)
        mujoco.mj_resetDataKeyframe(m, data, 0)
        mujoco.mj_forward(m, data)
        renderer = make_renderer(m, 320, 240)
        try:
            frames.append(render_frame(renderer, data, "overview").astype(int))
        finally:
            renderer.close()
    diff = np.abs(frames[0] - frames[1])
    assert 0 < diff.mean() < 2.55
