"""Parallel rendering: the same frames as one process, replay = the live video, and interrupts."""

from __future__ import annotations

import multiprocessing
import os
import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

import imageio.v2 as imageio
import numpy as np
import numpy.typing as npt
import pytest

from kr210_sim.cell.load import load_model
from kr210_sim.cli import main
from kr210_sim.errors import RenderError
from kr210_sim.jobs import run_job
from kr210_sim.media.recording import read_recording
from kr210_sim.media.render_pool import (
    HOLD,
    FrameRenderer,
    RenderPool,
    capped_workers,
    chunk_frames,
    default_workers,
    gl_threads_per_worker,
    render_recording,
)
from kr210_sim.media.video import VideoSettings
from kr210_sim.sim.runner import RunConfig

pytestmark = pytest.mark.render

CONFIG = RunConfig(cycles=1, seed=4, slot=5, randomize=True)
SMALL = {"width": 160, "height": 128, "quality": "fast"}


def _frames(path: Path) -> npt.NDArray[np.uint8]:
    return np.stack([f for f in imageio.get_reader(path)])  # list() fails: len() is inf


@pytest.fixture(scope="module")
def live(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, Any]:
    """A randomised cycle filmed by two render processes at 10 fps, recorded at 30 Hz."""
    folder = tmp_path_factory.mktemp("live")
    video = VideoSettings(folder / "live.mp4", ("overview", "gripper"), fps=10, tail=1.0, **SMALL)
    job = run_job(
        CONFIG, folder / "run.json", video=video, record=folder / "run.npz", render_workers=2
    )
    assert job.video_error is None
    return folder / "live.mp4", folder / "run.npz", job


def test_replay_reproduces_the_live_video_frame_for_frame(
    live: tuple[Path, Path, Any], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    video, rec, job = live
    out = tmp_path / "replay.mp4"
    # One process now (the reference render); the run's own video settings are the defaults.
    assert main(["replay", str(rec), "--video", str(out), "--workers", "1"]) == 0
    assert f"({job.video_frames} frames)" in capsys.readouterr().out
    a, b = _frames(video), _frames(out)
    assert a.shape == b.shape == (job.video_frames, 128, 320, 3)
    assert int(np.abs(a.astype(np.int16) - b).max()) == 0  # identical frames
    assert video.read_bytes() == out.read_bytes()  # and, the encoder being deterministic, bytes
    # The closing shot is in: the last frames show the bin camera, not the overview.
    assert np.abs(a[-1, :, :160].astype(np.int16) - a[len(a) // 2, :, :160]).mean() > 10


def test_parallel_frames_equal_a_single_process_render(
    live: tuple[Path, Path, Any], tmp_path: Path
) -> None:
    """The pool's frames, read back before encoding, against frames rendered here: with the
    shadows of the default quality, rasterised on each worker's own thread (LP_NUM_THREADS=0)
    there and by llvmpipe's thread pool here."""
    _, path, _ = live
    rec = read_recording(path)
    model = load_model()
    settings = VideoSettings(
        tmp_path / "unused.mp4", ("gripper", "bin"), **{**SMALL, "quality": "medium"}
    )
    picks = list(range(0, rec.frames, 3))
    expected = _pool_frames(model, settings, rec, picks, workers=1)
    got = _pool_frames(model, settings, rec, picks, workers=2)
    assert len(got) == len(expected) > 2 * 8  # more than one chunk per worker
    diff = max(
        int(np.abs(g.astype(np.int16) - e).max()) for g, e in zip(got, expected, strict=True)
    )
    assert diff == 0
    assert not multiprocessing.active_children()


def _pool_frames(
    model: Any, settings: VideoSettings, rec: Any, picks: list[int], workers: int
) -> list[npt.NDArray[np.uint8]]:
    """The frames a pool of ``workers`` makes of the recording's frames ``picks``, read back
    before encoding."""
    feeds = [
        (rec.arrays["qpos"][i], rec.shapes_at(i), rec.status(i), rec.arrays["tail"][i])
        for i in picks
    ]
    return _captured(model, settings, rec.target_geoms, workers, feeds)[0]


def _captured(
    model: Any,
    settings: VideoSettings,
    geoms: Any,
    workers: int,
    feeds: list[tuple[Any, Any, Any, Any]],
) -> tuple[list[npt.NDArray[np.uint8]], int | None]:
    """What a pool of ``workers`` gives for ``feeds`` (``feed``'s arguments), read back before
    encoding, and how many frames its in-process renderer reused (None with workers). Each frame
    is overwritten once read, as the encoder's overlay does: a renderer keeping it would show."""
    got: list[npt.NDArray[np.uint8]] = []

    class Capture(RenderPool):  # keep what the workers send instead of encoding it
        def _write(self, frame: npt.NDArray[np.uint8]) -> None:
            self._lines.popleft()
            got.append(frame.copy())
            frame[:] = 0
            self.written += 1

    pool = Capture(model, settings, geoms, workers=workers)
    assert pool.chunk == chunk_frames(settings) == 8
    try:
        for feed in feeds:
            pool.feed(*feed)
        reused = pool._local.reused if pool._local is not None else None
        assert pool.finish() == len(feeds)
    except BaseException:
        pool.abort(keep=False)
        raise
    return got, reused


def test_a_still_frame_is_drawn_once_and_its_pixels_are_a_fresh_draws(
    live: tuple[Path, Path, Any], tmp_path: Path
) -> None:
    """Positions within HOLD of the last frame drawn give that frame's pixels again; beyond
    HOLD, or with other target shapes, a frame is drawn."""
    _, path, _ = live
    rec = read_recording(path)
    settings = VideoSettings(
        tmp_path / "still.mp4", ("overview",), **{**SMALL, "quality": "medium"}
    )
    i = rec.frames // 2
    q, shapes, status = rec.arrays["qpos"][i], rec.shapes_at(i), rec.status(i)
    nudged = q.copy()
    nudged[0] += 0.5 * HOLD
    moved = q.copy()
    moved[0] += 0.01  # 0.01 rad of joint 1: the arm moves by pixels
    other = shapes.copy()
    other[0, 0] *= 1.5  # a wider cylinder
    fresh = FrameRenderer(load_model(), settings, rec.target_geoms)
    try:
        want = [fresh._draw(x, s, False) for x, s in ((q, shapes), (moved, shapes), (q, other))]
    finally:
        fresh.close()
    feeds = [(x, s, status, False) for x, s in ((q, shapes), (nudged, shapes), (q, shapes))]
    feeds += [(moved, shapes, status, False), (q, other, status, False)]
    got, reused = _captured(load_model(), settings, rec.target_geoms, 1, feeds)
    assert reused == 2  # drawn 3 times for 5
    assert [np.array_equal(g, w) for g, w in zip(got, [want[0]] * 3 + want[1:], strict=True)] == [
        True
    ] * 5
    assert not np.array_equal(want[0], want[1]) and not np.array_equal(want[0], want[2])


def test_workers_share_the_cores_and_a_worker_per_core_rasterises_on_its_own_thread() -> None:
    cores = default_workers()
    assert gl_threads_per_worker(cores) == gl_threads_per_worker(cores + 3) == 0
    assert gl_threads_per_worker(1) == (cores if cores > 1 else 0)


def test_replay_starts_no_more_render_processes_than_cores_or_frames(
    live: tuple[Path, Path, Any],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    import kr210_sim.media.render_pool as render_pool

    started: list[int] = []

    class Counted(RenderPool):
        def __init__(self, *args: Any) -> None:
            started.append(int(args[3]))
            super().__init__(*args)

    monkeypatch.setattr(render_pool, "RenderPool", Counted)
    _, rec, _ = live
    out = tmp_path / "few.mp4"
    argv = ["replay", str(rec), "--video", str(out), "--fps", "1", "--workers", "64"]
    assert main([*argv, "--width", "96", "--height", "64"]) == 0
    frames = len(_frames(out))
    assert started == [min(default_workers(), frames)]
    assert f"on {started[0]} worker(s)" in capsys.readouterr().err
    assert capped_workers(64, 3) == min(default_workers(), 3) and capped_workers(1, 0) == 1


def test_replay_resamples_and_takes_other_cameras(
    live: tuple[Path, Path, Any], tmp_path: Path
) -> None:
    _, rec, job = live
    out = tmp_path / "bin.mp4"
    argv = ["replay", str(rec), "--video", str(out), "--camera", "bin", "--fps", "5"]
    assert main([*argv, "--width", "96", "--height", "64", "--workers", "2"]) == 0
    frames = _frames(out)
    assert frames.shape[1:] == (64, 96, 3)
    assert abs(len(frames) - job.sim_time * 5) <= 1.5


def test_a_render_that_fails_leaves_no_file_and_an_earlier_one_untouched(
    live: tuple[Path, Path, Any], tmp_path: Path
) -> None:
    _, path, _ = live
    rec = read_recording(path)
    out = tmp_path / "v.mp4"
    out.write_bytes(b"an earlier video")
    settings = VideoSettings(out, ("overview",), **SMALL)
    killed: list[int] = []

    def kill_a_worker(frames: int, sim_time: float) -> None:
        if frames == 20 and not killed:
            child = multiprocessing.active_children()[0]
            killed.append(child.pid or 0)
            os.kill(child.pid or 0, signal.SIGKILL)

    with pytest.raises(RenderError, match=r"render worker \d stopped"):
        render_recording(rec, load_model(), settings, workers=2, progress=kill_a_worker)
    assert out.read_bytes() == b"an earlier video"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["v.mp4"]
    assert not multiprocessing.active_children()


def test_ctrl_c_during_a_replay_keeps_a_playable_partial_mp4(
    live: tuple[Path, Path, Any], tmp_path: Path
) -> None:
    _, rec, _ = live
    out = tmp_path / "partial.mp4"
    argv = [sys.executable, "-m", "kr210_sim", "replay", str(rec), "--video", str(out)]
    argv += [
        "--workers",
        "2",
        "--fps",
        "30",
        "--width",
        "320",
        "--height",
        "240",
        "--quality",
        "high",
    ]
    proc = subprocess.Popen(
        argv,
        cwd=tmp_path,
        text=True,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,  # its own process group, as a shell job would be
    )
    assert proc.stderr is not None
    line = proc.stderr.readline()  # the first progress line: frames are being written
    assert line.startswith("replay: "), line
    os.killpg(proc.pid, signal.SIGINT)  # what Ctrl-C in a terminal does
    stdout, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "interrupted (SIGINT)" in err
    frames = _frames(out)
    total = read_recording(rec).frames
    assert 1 <= len(frames) < total // 2 and f"({len(frames)} frames)" in stdout
    assert sorted(p.name for p in tmp_path.iterdir()) == ["partial.mp4"]
