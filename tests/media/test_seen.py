"""The video's overlay of what perception saw: the marker lands on the object it names, it
changes the frame there and nowhere far from it, and ``run --perceive --video`` draws it once
the cycle's look is done."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from kr210_sim.cli import main
from kr210_sim.media.recording import FrameStatus, target_shapes
from kr210_sim.media.render_pool import FrameRenderer
from kr210_sim.media.seen import SeenMarker
from kr210_sim.media.video import VideoSettings, overlay_lines
from kr210_sim.sim.session import episode_runner
from kr210_sim.util.paths import SCENES_DIR

import mujoco  # isort: skip

CELL = SCENES_DIR / "cells" / "cluttered.toml"


@pytest.fixture(scope="module")
def spawned() -> Any:
    """The cluttered cell with a cycle's target standing in its slot (seed 7, randomised)."""
    from kr210_sim.cell.load import model_at

    runner = episode_runner(7, randomize=True, model=model_at(CELL))
    _, k = runner.start_cycle(1, runner.slot_for_cycle())
    mujoco.mj_forward(runner.model, runner.cell.data)
    return runner, k


def _status(seen_at: Any) -> FrameStatus:
    return FrameStatus(3.0, 1, 1, 9, "lift", 0, 0, "", "seen target (75%)", seen_at)


def test_the_marker_projects_onto_the_object_through_the_views_camera(spawned: Any) -> None:
    runner, k = spawned
    model, data = runner.model, runner.cell.data
    settings = VideoSettings(Path("x.mp4"), cameras=("overview",), width=640, height=480)
    marker = SeenMarker(model, settings)
    centre = runner.cell.target_pose(k)[0]
    (uv,) = marker.pixels(data.qpos.copy(), centre)
    assert uv is not None
    renderer = mujoco.Renderer(model, 480, 640)
    try:
        renderer.enable_segmentation_rendering()
        renderer.update_scene(data, camera="overview")
        seg = renderer.render()
    finally:
        renderer.close()
    geom = int(seg[int(uv[1]), int(uv[0]), 0])
    assert int(model.geom_bodyid[geom]) == int(runner.cell.handles.target_bodies[k])
    # a point behind the camera has no pixel
    behind = 2 * data.cam_xpos[model.camera("overview").id] - centre
    assert marker.pixels(data.qpos.copy(), behind) == [None]


def test_the_marker_changes_the_frame_at_the_object_and_nowhere_far(spawned: Any) -> None:
    runner, k = spawned
    model, data = runner.model, runner.cell.data
    settings = VideoSettings(Path("x.mp4"), cameras=("overview", "overview"), width=320, height=240)
    frames = FrameRenderer(model, settings, runner.cell.handles.target_geoms)
    try:
        geoms = runner.cell.handles.target_geoms
        frame = frames.render(data.qpos.copy(), target_shapes(model, geoms), False)
    finally:
        frames.close()
    marker = SeenMarker(model, settings)
    centre = runner.cell.target_pose(k)[0]
    (u, v), _ = marker.pixels(data.qpos.copy(), centre)
    untouched = marker.draw(frame.copy(), data.qpos.copy(), _status(None))
    assert np.array_equal(untouched, frame)
    drawn = marker.draw(frame.copy(), data.qpos.copy(), _status(tuple(centre)))
    changed = np.abs(drawn.astype(int) - frame.astype(int)).max(axis=2) > 40
    rows, cols = np.nonzero(changed)
    for view in (0, 1):  # a ring around the object in each view
        mine = (cols >= view * 320) & (cols < (view + 1) * 320)
        du, dv = cols[mine] - (u + view * 320), rows[mine] - v
        near = np.hypot(du, dv) <= marker.radius + 2
        assert near.sum() > 2 * marker.radius  # the ring
        assert (du[~near] > -marker.radius - 200).all()  # the rest: its label, beside it
    assert not changed[:, :20].any() and not changed[-20:, :].any()  # far away: nothing


def test_the_overlay_names_what_was_seen() -> None:
    lines = overlay_lines(_status((0.0, 0.0, 1.0)).as_status(), 3.0)
    assert lines[-1] == "seen target (75%)"
    assert all("seen" not in line for line in overlay_lines({"cycle": 1}, 0.0))


def _frame(video: Path, n: int, out: Path) -> np.ndarray:
    from imageio_ffmpeg import get_ffmpeg_exe
    from PIL import Image

    cmd = [get_ffmpeg_exe(), "-loglevel", "error", "-y", "-i", str(video)]
    subprocess.run([*cmd, "-vf", rf"select=eq(n\,{n})", "-vframes", "1", str(out)], check=True)
    return np.asarray(Image.open(out).convert("RGB")).astype(int)


def test_a_perceived_run_marks_the_estimate_on_its_video_after_the_look(tmp_path: Path) -> None:
    video, report = tmp_path / "v.mp4", tmp_path / "v.json"
    argv = ["run", "--perceive", "--cycles", "1", "--seed", "7", "--randomize", "--cell"]
    argv += [str(CELL), "--video", str(video), "--width", "320", "--height", "240"]
    argv += ["--fps", "10", "--quality", "fast", "--render-workers", "1", "--report", str(report)]
    assert main(argv) == 0
    cycle = json.loads(report.read_text())["cycles"][0]
    assert cycle["perception"]["right_object"]
    from kr210_sim.cell.load import model_at

    model = model_at(CELL)
    marker = SeenMarker(model, VideoSettings(video, width=320, height=240))
    ((u, v),) = marker.pixels(model.qpos0.copy(), cycle["target"]["position"])  # a fixed camera
    yy, xx = np.mgrid[0:240, 0:320]
    ring = np.abs(np.hypot(xx - u, yy - v) - marker.radius) <= 1.5

    def yellow(frame: np.ndarray) -> int:
        r, g, b = frame[..., 0], frame[..., 1], frame[..., 2]
        return int(((r > 190) & (g > 160) & (b < 90) & ring).sum())

    assert yellow(_frame(video, 1, tmp_path / "first.png")) < 3  # spawning: nothing seen yet
    assert yellow(_frame(video, 30, tmp_path / "later.png")) > 10  # 3 s: seen, and marked
