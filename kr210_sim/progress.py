"""A one-line progress display for long work (video export, evaluations).

On a terminal the line is redrawn in place a few times a second; in a log (CI, a pipe) a new
line is written every few seconds instead, so logs stay short.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

#: Seconds between redraws on a terminal and between lines in a log.
TTY_INTERVAL = 0.25
LOG_INTERVAL = 5.0


def bar(fraction: float, width: int = 24) -> str:
    """A text bar ``[####----]`` of ``width`` cells, ``fraction`` (clipped to [0, 1]) filled."""
    filled = int(width * min(1.0, max(0.0, fraction)))
    return "[" + "#" * filled + "-" * (width - filled) + "]"


class ProgressLine:
    """Where and how often a progress line is written.

    Args:
        stream: Where to write (stderr).
        log_interval: Seconds between lines when the stream is not a terminal [s].
    """

    def __init__(self, stream: TextIO | None = None, log_interval: float = LOG_INTERVAL) -> None:
        self.stream = stream or sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.interval = TTY_INTERVAL if self.tty else log_interval
        self.start = time.perf_counter()
        self.last = 0.0

    @property
    def elapsed(self) -> float:
        """Wall time since the start [s]."""
        return time.perf_counter() - self.start

    def due(self) -> bool:
        """Whether enough time has passed for another line (and, if so, restart the clock)."""
        now = time.perf_counter()
        if now - self.last < self.interval:
            return False
        self.last = now
        return True

    def show(self, line: str) -> None:
        """Write ``line``: in place on a terminal, as a new line otherwise."""
        self.stream.write(("\r" + line) if self.tty else (line + "\n"))
        self.stream.flush()

    def end(self, final: str | None = None) -> None:
        """Finish the display, with an optional closing line."""
        if self.tty:
            self.stream.write("\r" if final is not None else "\n")
        if final is not None:
            self.stream.write(final + "\n")
        self.stream.flush()
