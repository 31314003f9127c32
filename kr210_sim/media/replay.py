"""``replay``: render a recording (``run --record``) to MP4, with the model it was made with.

:func:`open_recording` reads a recording and loads its scene or cell, checked against it (also
for ``view --replay``); :func:`replay_job` renders it on the render pool with the run's own
video settings unless others are given.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from kr210_sim.cell.load import model_at
from kr210_sim.errors import ConfigError
from kr210_sim.media.recording import Recording, check_model, read_recording
from kr210_sim.media.render_pool import (
    capped_workers,
    default_workers,
    frame_indices,
    render_recording,
)
from kr210_sim.media.video import VideoSettings
from kr210_sim.util.outputs import check_distinct, check_writable, is_stream
from kr210_sim.util.paths import SCENE_PATH

import mujoco  # isort: skip


def open_recording(
    path: Path, scene: Path | None = None
) -> tuple[Recording, mujoco.MjModel, Path | None]:
    """Read the recording at ``path`` and load the model it was made with (``scene``, else the
    scene it names, else the committed one), checked against it (``replay``, ``view --replay``).

    Returns:
        The recording, the model, and the scene path used (None: the committed scene).

    Raises:
        RecordingError: The file is not a readable recording or was made with another model.
        SceneError: The scene cannot be loaded.
    """
    recording = read_recording(path)
    if scene is None and recording.meta.get("scene"):
        scene = Path(recording.meta["scene"])
    model = model_at(scene)
    check_model(path, recording, model)
    return recording, model, scene


@dataclass(frozen=True, slots=True)
class ReplayResult:
    """What :func:`replay_job` made.

    Attributes:
        video: The settings the MP4 was rendered with (its path included).
        frames: Frames written (0: no MP4).
        workers: Processes that rendered it.
        interrupted: The interrupt that stopped the render early (the frames so far are kept),
            or None.
    """

    video: VideoSettings
    frames: int
    workers: int
    interrupted: KeyboardInterrupt | None


def replay_job(
    recording: Path,
    video_path: Path | None = None,
    options: dict[str, Any] | None = None,
    scene: Path | None = None,
    workers: int | None = None,
    progress: Callable[[int, float, int | None], None] | None = None,
) -> ReplayResult:
    """Render a recording (``run --record``) to MP4: the ``replay`` command.

    Args:
        recording: The recording (``.npz``).
        video_path: The MP4 (default: the recording's path with ``.mp4``).
        options: Video settings given (``cameras``, ``width``, ``height``, ``fps``,
            ``quality``); the rest are the run's own when it had a video, else the defaults,
            and fps defaults to the recording's rate.
        scene: The scene or cell the recording was made with (default: the one it names).
        workers: Render processes (default: one per core; 1 renders in this process).
        progress: Called with (frames written, simulated time [s], total frames or None).

    Raises:
        RecordingError: The recording is unreadable or was made with another model.
        ConfigError: The MP4 path cannot be written or names an input.
        RenderError: Rendering or encoding failed.
    """
    rec, model, scene = open_recording(recording, scene)
    made: dict[str, Any] = dict(rec.meta.get("video") or {})
    if "cameras" in made:
        made["cameras"] = tuple(made["cameras"])
    given = options or {}
    fps = given.get("fps", made.get("fps", round(rec.rate)))
    path = video_path if video_path is not None else recording.with_suffix(".mp4")
    video = VideoSettings(path=path, **{**made, **given, "fps": fps})
    check_writable(video.path)
    if is_stream(video.path):
        raise ConfigError(f"--video {video.path}: an MP4 needs a regular, seekable file")
    check_distinct(
        {"--video": video.path},
        {"the recording": recording, "--scene": scene if scene is not None else SCENE_PATH},
    )
    # At most one process per core and per frame to draw.
    workers = capped_workers(workers or default_workers(), len(frame_indices(rec, fps)))
    total = rec.frames if fps == rec.rate else None

    def report(frames: int, sim_time: float) -> None:
        if progress is not None:
            progress(frames, sim_time, total)

    frames, interrupted = render_recording(rec, model, video, workers, report)
    return ReplayResult(video, frames, workers, interrupted)
