"""The progress line: throttling, in-place redraw on a terminal, plain lines in a log."""

from __future__ import annotations

import io

from kr210_sim.progress import ProgressLine, bar


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
