"""What makes pixels: rendering, video encoding, the render pool, recordings, plots and pictures."""

from __future__ import annotations

from kr210_sim.media.recording import Recording, read_recording, write_recording
from kr210_sim.media.render import make_renderer, snapshot
from kr210_sim.media.video import VideoSettings

__all__ = [
    "Recording",
    "VideoSettings",
    "make_renderer",
    "read_recording",
    "snapshot",
    "write_recording",
]
