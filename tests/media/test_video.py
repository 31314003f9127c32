"""Video export: a short MP4 read back, physics unchanged by filming, and the error paths."""

from __future__ import annotations

import json
from pathlib import Path

import imageio.v2 as imageio
import numpy as np
import pytest

from kr210_sim.cli import main
from kr210_sim.errors import ConfigError
from kr210_sim.jobs import run_job
from kr210_sim.media.video import VideoSettings, overlay_lines
from kr210_sim.score.report import strip_wall
from kr210_sim.sim.runner import RunConfig

pytestmark = pytest.mark.render

CONFIG = RunConfig(cycles=1, seed=4, slot=5)


def test_short_video_reads_back_and_filming_leaves_the_report_unchanged(tmp_path: Path) -> None:
    video = VideoSettings(
        tmp_path / "run.mp4", ("overview", "gripper"), 160, 128, fps=10, quality="fast", tail=0.5
    )
    filmed = run_job(CONFIG, tmp_path / "filmed.json", video=video)
    run_job(CONFIG, tmp_path / "plain.json")
    assert filmed.video_error is None and filmed.video_frames > 0
    frames = [f for f in imageio.get_reader(video.path)]  # list() fails: len() is inf
    # One frame per 1/fps of simulated time, the closing shot included.
    assert len(frames) == filmed.video_frames
    assert abs(len(frames) - filmed.sim_time * video.fps) <= 1.5
    assert frames[0].shape == (128, 320, 3)  # two views side by side
    stack = np.stack(frames).astype(np.float64)
    assert stack.std(axis=(1, 2, 3)).min() > 5.0  # no blank frame
    assert np.abs(np.diff(stack, axis=0)).mean(axis=(1, 2, 3)).max() > 1.0  # it moves
    # The overlay is in the top-left corner: white text on a dark box.
    assert frames[0][:20, :60].max() > 200
    a = json.loads((tmp_path / "filmed.json").read_text())
    b = json.loads((tmp_path / "plain.json").read_text())
    assert a["summary"]["successes"] == 1
    assert strip_wall(a) == strip_wall(b)


def test_overlay_lines() -> None:
    status: dict[str, object] = {
        "cycle": 3,
        "cycles": 10,
        "slot": 7,
        "phase": "retreat",
        "done": 2,
        "successes": 2,
    }
    assert overlay_lines(status, 12.345) == [
        "cycle 3/10   slot 7",
        "phase: lift",
        "score: 2/2",
        "t =  12.35 s",
    ]


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"width": 100}, "multiple of 16"),
        ({"height": 0}, "multiple of 16"),
        ({"fps": 0}, "fps must be 1-120"),
        ({"quality": "ultra"}, "quality must be one of"),
        ({"cameras": ()}, "at least one camera"),
        ({"path": Path("run.avi")}, "must end in .mp4"),
    ],
)
def test_settings_are_checked(kwargs: dict[str, object], message: str) -> None:
    args: dict[str, object] = {"path": Path("run.mp4"), **kwargs}
    with pytest.raises(ConfigError, match=message):
        VideoSettings(**args)  # type: ignore[arg-type]


def _one_line_error(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.startswith("kr210_sim")]
    assert len(lines) == 1 and "Traceback" not in err
    return lines[0]


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--width", "100"], "must be a multiple of 16"),
        (["--fps", "500"], "must be 1-120"),
        (["--quality", "ultra"], "invalid choice"),
    ],
)
def test_bad_video_arguments(
    tmp_path: Path, extra: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["run", "--video", str(tmp_path / "v.mp4"), *extra])
    assert exc.value.code == 2
    assert message in capsys.readouterr().err


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--camera", "ceiling"], "no camera 'ceiling'"),
        (["--width", "9008"], "too large: at most 8192 px"),
    ],
)
def test_bad_video_settings_fail_before_the_run(
    tmp_path: Path, extra: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["run", "--cycles", "1", "--report", str(tmp_path / "r.json")]
    assert main([*argv, "--video", str(tmp_path / "v.mp4"), *extra]) == 2
    assert message in _one_line_error(capsys)
    assert not (tmp_path / "r.json").exists()  # rejected before anything ran


def test_video_options_need_video(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", "--cycles", "1", "--camera", "bin"]) == 2
    assert "need --video" in _one_line_error(capsys)


def test_unwritable_video_path(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("")
    argv = ["run", "--cycles", "1", "--report", str(tmp_path / "r.json")]
    assert main([*argv, "--video", str(blocker / "v.mp4")]) == 2
    assert "is a file, not a folder" in _one_line_error(capsys)


def test_no_ffmpeg_still_writes_the_report(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import imageio_ffmpeg

    def missing() -> str:
        raise RuntimeError("No ffmpeg exe could be found")

    monkeypatch.setattr(imageio_ffmpeg, "get_ffmpeg_exe", missing)
    report = tmp_path / "r.json"
    argv = ["run", "--cycles", "1", "--slot", "1", "--report", str(report)]
    assert main([*argv, "--video", str(tmp_path / "v.mp4")]) == 2
    line = _one_line_error(capsys)
    assert "ffmpeg is not available" in line and "pip install imageio-ffmpeg" in line
    assert "the report was written" in line
    assert json.loads(report.read_text())["summary"]["successes"] == 1


def test_no_gl_backend_names_mujoco_gl(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import mujoco

    def no_gl(*args: object, **kwargs: object) -> None:
        raise mujoco.FatalError("gladLoadGL error")

    monkeypatch.setattr(mujoco, "Renderer", no_gl)  # in this process: render here
    report = tmp_path / "r.json"
    argv = ["run", "--cycles", "1", "--slot", "1", "--report", str(report)]
    assert main([*argv, "--video", str(tmp_path / "v.mp4"), "--render-workers", "1"]) == 2
    line = _one_line_error(capsys)
    assert "MUJOCO_GL" in line and "libegl1" in line
    assert report.exists()


def test_a_tiling_wider_than_the_encoder_is_refused_up_front(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    video = tmp_path / "v.mp4"
    video.write_bytes(b"a good video")
    cams = ["--camera", "overview", "--camera", "shelf", "--camera", "bin"]
    argv = ["run", "--cycles", "1", "--report", str(tmp_path / "r.json"), "--video", str(video)]
    assert main([*argv, *cams, "--width", "8192", "--height", "64"]) == 2
    assert "24576 px wide video; the H.264 encoder takes at most 16384" in _one_line_error(capsys)
    assert video.read_bytes() == b"a good video"
    assert not (tmp_path / "r.json").exists()


def _fake_ffmpeg(path: Path, version: str) -> Path:
    """A script that answers -version like ffmpeg and then fails (or, not ffmpeg at all)."""
    path.write_text(f"#!/bin/sh\n[ \"$1\" = -version ] && echo '{version}' && exit 0\nexit 1\n")
    path.chmod(0o755)
    return path


def test_a_failed_encode_leaves_an_earlier_video_untouched(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    exe = _fake_ffmpeg(tmp_path / "ffmpeg", "ffmpeg version 0-broken")
    monkeypatch.setenv("IMAGEIO_FFMPEG_EXE", str(exe))
    out = tmp_path / "out"
    out.mkdir()
    video = out / "v.mp4"
    video.write_bytes(b"a good video")
    argv = ["run", "--cycles", "1", "--slot", "5", "--report", str(out / "r.json")]
    small = ["--width", "160", "--height", "128", "--fps", "5", "--quality", "fast"]
    assert main([*argv, "--video", str(video), *small]) == 2
    line = _one_line_error(capsys)
    assert "video" in line and "the report was written" in line
    assert video.read_bytes() == b"a good video"
    assert sorted(p.name for p in out.iterdir()) == ["r.json", "v.mp4"]  # no temporary left


@pytest.mark.parametrize(
    ("exe", "message"),
    [
        ("/nonexistent/ffmpeg", "IMAGEIO_FFMPEG_EXE=/nonexistent/ffmpeg names no file"),
        ("{d}/notffmpeg", "is not ffmpeg (its -version says 'GNU true 9')"),
    ],
)
def test_imageio_ffmpeg_exe_errors_name_the_variable(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, exe: str, message: str
) -> None:
    from kr210_sim.errors import RenderError
    from kr210_sim.media.video import ffmpeg_exe

    _fake_ffmpeg(tmp_path / "notffmpeg", "GNU true 9")
    monkeypatch.setenv("IMAGEIO_FFMPEG_EXE", exe.format(d=tmp_path))
    with pytest.raises(RenderError) as err:
        ffmpeg_exe()
    text = str(err.value)
    assert message in text and "IMAGEIO_FFMPEG_EXE" in text and "\n" not in text


def test_the_overlay_shades_its_box_writes_white_text_and_keeps_few_masks() -> None:
    from kr210_sim.media.video import _Overlay

    overlay = _Overlay(480)
    grey = np.full((480, 640, 3), 120, dtype=np.uint8)
    lines = ["cycle 3/10   slot 5", "phase: carry", "score: 2/2", "t =  12.34 s"]
    a = overlay.draw(grey.copy(), lines)
    box = a[: 4 * int(overlay.size * 1.3), :100]
    # the shade: 120 * (255 - 150) / 255 = 49, text up to white, nothing outside the box
    assert int(np.median(box)) == 49 and box.max() >= 250
    assert (a[300:, 300:] == 120).all()
    assert np.array_equal(a, overlay.draw(grey.copy(), lines))  # the kept masks draw the same
    for k in range(3 * overlay.CACHE):
        overlay.draw(grey.copy(), [f"t = {k:6.2f} s"])
    assert len(overlay._masks) <= overlay.CACHE
