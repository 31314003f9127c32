"""The progress line: throttling, in-place redraw on a terminal, plain lines in a log; the
video's estimate to finish."""

from __future__ import annotations

import io
import time

import pytest

from kr210_sim.util.progress import ProgressLine, VideoProgress, bar


class _Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_bar() -> None:
    assert bar(0.0, 8) == "[--------]"
    assert bar(0.5, 8) == "[####----]"
    assert bar(1.7, 8) == "[########]"


def test_log_lines_are_throttled() -> None:
    stream = io.StringIO()
    line = ProgressLine(stream, log_interval=60.0)
    assert line.due()  # the first line is due at once
    line.show("a")
    assert not line.due()  # then only after the interval
    line.end("done")
    assert stream.getvalue() == "a\ndone\n"


def test_terminal_redraws_in_place() -> None:
    stream = _Tty()
    line = ProgressLine(stream)
    assert line.tty
    line.show("a")
    line.show("b")
    line.end()
    assert stream.getvalue() == "\ra\rb\n"


def test_video_progress_estimate_and_line() -> None:
    stream = io.StringIO()
    p = VideoProgress(4, stream, tail=2.0)
    p.line.start = time.perf_counter() - 10.0  # 10 s of wall time so far
    assert p.eta(0.5) is None  # too early to tell
    assert p.eta(11.0) == pytest.approx(10.0 * (4 * 5.0 + 2.0 - 11.0) / 11.0, rel=0.02)  # prior
    p.cycle_done(2, 12.0)  # 6 s a cycle measured: 26 s of simulated time in all
    assert p.eta(13.0) == pytest.approx(10.0, rel=0.02)
    p(1, 0.002)  # the first frame: no estimate yet
    assert stream.getvalue().endswith("eta    ?\n")
    p.line.last = 0.0
    p(300, 13.0)
    p.finish(300)
    lines = stream.getvalue().splitlines()
    assert lines[1].startswith("video [############------------] cycle 2/4  300 frames")
    assert "eta   10 s" in lines[1]
    assert lines[2].startswith("video: 300 frames in")
