"""Video export: settings, the text overlay and the encoder (H.264 MP4), and the progress bar.

Frames are spaced ``1 / fps`` of *simulated* time, so the video plays at real speed. They are
taken as states by :class:`kr210_sim.media.recording.StateRecorder` (a step hook that only reads
``MjData``: a run with and without video gives the same report) and rendered, in parallel, by
:class:`kr210_sim.media.render_pool.RenderPool`, which hands them in order to the encoder here.

The encoder (:class:`_Writer`) works on a background thread: it draws the text overlay and pipes
the frame to ffmpeg (imageio-ffmpeg), which encodes in its own process, so the next frame is
received while the previous one is overlaid, piped and encoded.
"""

from __future__ import annotations

import os
import queue
import signal
import threading
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from kr210_sim.errors import ConfigError, RenderError, one_line
from kr210_sim.util.outputs import commit, discard, temp_beside

#: Quality presets: (shadows, shadow map size [px], MSAA samples). fast and medium also draw
#: the video's level of detail (:func:`kr210_sim.media.render.draw_level`: lighter meshes,
#: textures as their mean colour, coarser built-in shapes). medium's 512 px map
#: looks the same at 640x480 (soft shadows) and costs 4 ms a frame less than 1024 in software.
QUALITY: dict[str, tuple[bool, int, int]] = {
    "fast": (False, 1024, 0),
    "medium": (True, 512, 0),
    "high": (True, 4096, 4),
}


#: H.264 settings per quality: (CRF, x264 preset). Faster presets leave more CPU to rendering.
ENCODING: dict[str, tuple[int, str]] = {
    "fast": (23, "ultrafast"),
    "medium": (21, "veryfast"),
    "high": (18, "medium"),
}


@dataclass(frozen=True, slots=True)
class VideoSettings:
    """What to record.

    Attributes:
        path: Output MP4 path.
        cameras: Camera names; more than one tiles the views side by side.
        width: Width of each view [px], a multiple of 16.
        height: Height [px], a multiple of 16.
        fps: Frames per second of simulated time.
        quality: One of :data:`QUALITY` (fast: no shadows; medium: shadows; high: shadows with a
            large shadow map and 4x multisampling).
        tail: Seconds of the bin camera appended after the last cycle [s].
    """

    path: Path
    cameras: tuple[str, ...] = ("overview",)
    width: int = 640
    height: int = 480
    fps: int = 30
    quality: str = "medium"
    tail: float = 2.5

    def __post_init__(self) -> None:
        if not self.cameras:
            raise ConfigError("give at least one camera")
        for name, v in (("width", self.width), ("height", self.height)):
            if v < 16 or v % 16:
                raise ConfigError(f"video {name} must be a positive multiple of 16, got {v}")
        if not 1 <= self.fps <= 120:
            raise ConfigError(f"fps must be 1-120, got {self.fps}")
        if self.quality not in QUALITY:
            raise ConfigError(f"quality must be one of {', '.join(QUALITY)}, got {self.quality!r}")
        if self.path.suffix.lower() != ".mp4":
            raise ConfigError(f"video path must end in .mp4, got {self.path}")
        tiled = self.width * len(self.cameras)
        if tiled > MAX_ENCODE_SIDE:
            raise ConfigError(
                f"{len(self.cameras)} views of {self.width} px tile a {tiled} px wide video; "
                f"the H.264 encoder takes at most {MAX_ENCODE_SIDE}: lower --width or the cameras"
            )


#: Largest frame side the H.264 encoder (libx264) accepts [px]; measured: 16384 x 8192 encodes,
#: 16400 wide does not.
MAX_ENCODE_SIDE = 16384


def _check_ffmpeg(exe: str, origin: str) -> None:
    """Raise RenderError unless ``exe`` runs and says it is ffmpeg."""
    import subprocess

    try:
        out = subprocess.run(
            [exe, "-version"], capture_output=True, text=True, timeout=20, check=False
        ).stdout
    except (OSError, subprocess.SubprocessError) as exc:
        raise RenderError(f"{origin} cannot be run ({exc})") from exc
    if not out.startswith("ffmpeg version"):
        first = (out.splitlines() or ["no output"])[0][:60]
        raise RenderError(f"{origin} is not ffmpeg (its -version says {first!r})")


def ffmpeg_exe() -> str:
    """Path of the ffmpeg binary imageio-ffmpeg uses, checked to run and to be ffmpeg.

    ``IMAGEIO_FFMPEG_EXE`` names another binary; errors about it name the variable.

    Raises:
        RenderError: When no working ffmpeg is available (one line: what to do).
    """
    env = os.environ.get("IMAGEIO_FFMPEG_EXE")
    if env:
        import shutil

        origin = f"IMAGEIO_FFMPEG_EXE={env}"
        exe = shutil.which(env) or env
        if not os.path.isfile(exe):
            raise RenderError(
                f"{origin} names no file: point it at an ffmpeg binary, or unset it to use "
                "imageio-ffmpeg's own"
            )
        if not os.access(exe, os.X_OK):
            raise RenderError(f"{origin} is not executable: chmod +x it, or unset it")
        _check_ffmpeg(exe, f"{origin} (unset it to use imageio-ffmpeg's own ffmpeg)")
        return exe
    try:
        import imageio_ffmpeg

        exe = str(imageio_ffmpeg.get_ffmpeg_exe())
    except Exception as exc:
        reason = " ".join(str(exc).split())
        raise RenderError(
            f"ffmpeg is not available ({reason}): pip install imageio-ffmpeg, or set "
            "IMAGEIO_FFMPEG_EXE to an ffmpeg binary"
        ) from exc
    if not os.access(exe, os.X_OK):
        raise RenderError(f"ffmpeg at {exe} is not executable: reinstall imageio-ffmpeg")
    _check_ffmpeg(exe, f"imageio-ffmpeg's ffmpeg at {exe} (reinstall imageio-ffmpeg)")
    return exe


#: How the runner's phase names read in the overlay where they differ from the name (the cycle
#: plan's phases are its steps' own, :class:`kr210_sim.plan.cycle.CyclePlan`; a new one reads
#: as its name).
PHASE_LABELS = {
    "retreat": "lift",
    "bin_emptied": "bin emptied",
    "shelf_cleared": "shelf cleared",
}


def overlay_lines(status: dict[str, object], sim_time: float) -> list[str]:
    """The overlay text for the runner's ``status`` at simulated time ``sim_time`` [s]: cycle,
    slot, phase, score, time, the event between cycles being shown (bin emptied, ...) and, with
    ``--perceive``, what the cycle's look recognised."""
    phase = str(status.get("phase", ""))
    done = int(status.get("done", 0))  # type: ignore[call-overload]
    return [
        f"cycle {status.get('cycle', 0)}/{status.get('cycles', 0)}   slot {status.get('slot', 0)}",
        f"phase: {PHASE_LABELS.get(phase, phase)}",
        f"score: {status.get('successes', 0)}/{done}",
        f"t = {sim_time:6.2f} s",
    ] + [str(status[k]) for k in ("event", "seen") if status.get(k)]


class _Overlay:
    """Draws the status text onto frames: a translucent dark box, white text (PIL's font).

    Each line's text is drawn once into an alpha mask and kept (most lines repeat from frame to
    frame; the time line is new every frame); the box is shaded and the masks laid on with
    NumPy, on the box's pixels only: 0.2 ms a frame at 640x480 against 1.3 ms drawing every
    line with PIL.
    """

    #: Opacity of the box's black shade [0-255].
    SHADE = 150
    #: Text masks kept (lines seen lately).
    CACHE = 64

    def __init__(self, height: int) -> None:
        from PIL import ImageFont

        self.size = max(12, height // 30)
        self.font = ImageFont.load_default(size=self.size)
        self._masks: dict[str, npt.NDArray[np.uint16]] = {}

    def _mask(self, text: str, width: int, height: int) -> npt.NDArray[np.uint16]:
        """The text's coverage (0-255), ``height`` x ``width`` px, drawn at the origin."""
        mask = self._masks.get(text)
        if mask is None or mask.shape != (height, width):
            from PIL import Image, ImageDraw

            img = Image.new("L", (width, height), 0)
            ImageDraw.Draw(img).text((0, 0), text, font=self.font, fill=255)
            mask = np.asarray(img, dtype=np.uint16)
            if len(self._masks) >= self.CACHE:
                self._masks.pop(next(iter(self._masks)))
            self._masks[text] = mask
        return mask

    def draw(self, frame: npt.NDArray[np.uint8], lines: list[str]) -> npt.NDArray[np.uint8]:
        """Draw ``lines`` in a translucent box in the top-left corner of ``frame`` (in place)."""
        pad = self.size // 2
        line_h = int(self.size * 1.3)
        w = max(int(self.font.getlength(t)) for t in lines) + 2 * pad
        h = len(lines) * line_h + 2 * pad
        w, h = min(w, frame.shape[1]), min(h, frame.shape[0])
        box = frame[:h, :w].astype(np.uint16) * (255 - self.SHADE) // 255
        for i, text in enumerate(lines):
            y = pad + i * line_h
            if y >= h or pad >= w:
                break
            mh, mw = min(line_h, h - y), w - pad
            m = self._mask(text, mw, mh)[:, :, None]
            part = box[y : y + mh, pad : pad + mw]
            part += (255 - part) * m // 255
        frame[:h, :w] = box
        return frame


class _Writer:
    """Overlays and encodes frames on a background thread, into a temporary file beside the
    destination that :meth:`close` moves into place (a failed encode leaves any earlier file at
    the destination as it was)."""

    def __init__(self, settings: VideoSettings) -> None:
        import imageio.v2 as imageio

        ffmpeg_exe()
        self.path = settings.path
        self.overlay = _Overlay(settings.height)
        crf, preset = ENCODING[settings.quality]
        self.tmp = temp_beside(settings.path)
        try:
            self.writer = imageio.get_writer(
                str(self.tmp),
                fps=settings.fps,
                codec="libx264",
                macro_block_size=16,
                pixelformat="yuv420p",
                ffmpeg_log_level="error",
                output_params=["-crf", str(crf), "-preset", preset],
            )
        except Exception as exc:
            discard(self.tmp)
            reason = " ".join(str(exc).split())
            raise RenderError(
                f"cannot start the video encoder for {settings.path}: {reason}"
            ) from exc
        self.queue: queue.Queue[tuple[npt.NDArray[np.uint8], list[str]] | None] = queue.Queue(8)
        self.error: Exception | None = None
        self.frames = 0
        self.thread = threading.Thread(target=self._run, name="kr210-video", daemon=True)
        self.thread.start()

    def _run(self) -> None:
        # ffmpeg is started (forked) from this thread on the first frame. A Ctrl-C to the
        # process group that lands in the child between fork and exec would raise in the
        # child's Python code ("Exception ignored ... _after_fork"): block the interrupt
        # signals here (the main thread still gets them), so the child inherits them blocked.
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM, signal.SIGHUP})
        while True:
            item = self.queue.get()
            if item is None:
                return
            if self.error is not None:
                continue
            try:
                frame, lines = item
                self.writer.append_data(self.overlay.draw(frame, lines))
                self.frames += 1
            except Exception as exc:  # surfaced on the main thread
                self.error = exc

    def put(self, frame: npt.NDArray[np.uint8], lines: list[str]) -> None:
        if self.error is not None:
            raise RenderError(f"video encoding failed: {self.error}")
        self.queue.put((frame, lines))

    def discard(self) -> None:
        """Stop encoding and remove the temporary file (an earlier file at the destination stays
        as it was)."""
        self.error = self.error or RenderError("discarded")
        self.queue.put(None)
        self.thread.join()
        try:
            self.writer.close()
        except Exception:
            pass
        discard(self.tmp)

    def close(self) -> None:
        """Finish encoding and move the file into place.

        Raises:
            RenderError: When encoding failed (the temporary file is removed).
        """
        self.queue.put(None)
        self.thread.join()
        try:
            self.writer.close()
        except Exception as exc:
            if self.error is None:
                self.error = exc
        if self.error is not None or self.frames == 0:
            discard(self.tmp)
            if self.error is not None:
                raise RenderError(
                    f"video encoding failed: {one_line(self.error) or type(self.error).__name__}"
                )
            return
        try:
            commit(self.tmp, self.path)
        except ConfigError as exc:
            raise RenderError(str(exc)) from exc
