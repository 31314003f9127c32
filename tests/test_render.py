"""Offscreen stills (needs an OpenGL backend: EGL on headless machines)."""

from __future__ import annotations

from pathlib import Path

import imageio.v3 as iio
import mujoco
import numpy as np
import pytest

from kr210_sim.cell.load import load_model
from kr210_sim.errors import ConfigError
from kr210_sim.media.render import make_renderer, snapshot

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
