"""A one-line progress display for long work (video export, evaluations).

:class:`VideoProgress` is the video export's line (cycles, frames, the estimate to finish).

On a terminal the line is redrawn in place a few times a second; in a log (CI, a pipe) a new
line is written every few seconds instead, so logs stay short.
"""

from __future__ import annotations

import sys
import time
from typing import Any, TextIO

#: Simulated length of a cycle assumed by the video's estimate before one has ended [s].
PRIOR_CYCLE_TIME = 5.0
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


class VideoProgress:
    """A one-line progress bar on stderr: cycles, frames, simulated time and the estimate.

    The estimate scales the wall time so far by the simulated time still to come: the simulated
    length of a cycle measured so far (a prior of :data:`PRIOR_CYCLE_TIME` before the first one
    ends) times the cycles left, plus the closing shot.

    Args:
        total_cycles: Cycles in the run.
        stream: Where to write (stderr).
        tail: Seconds of closing shot after the last cycle [s].
    """

    def __init__(self, total_cycles: int, stream: Any = None, tail: float = 0.0) -> None:
        self.total = total_cycles
        self.tail = tail
        self.line = ProgressLine(stream)
        self.cycles_done = 0
        self._sim_at_cycle = 0.0

    def cycle_done(self, n: int, sim_time: float) -> None:
        """Record that cycle ``n`` ended at simulated time ``sim_time`` [s]."""
        self.cycles_done = n
        self._sim_at_cycle = sim_time

    def eta(self, sim_time: float) -> float | None:
        """Estimated wall time to finish [s], or None in the first simulated second (too early
        to tell the wall time a simulated second costs)."""
        if sim_time < 1.0:
            return None
        per_cycle = self._sim_at_cycle / self.cycles_done if self.cycles_done else PRIOR_CYCLE_TIME
        total_sim = self.total * per_cycle + self.tail
        return max(0.0, self.line.elapsed * (total_sim - sim_time) / sim_time)

    def __call__(self, frames: int, sim_time: float) -> None:
        if not self.line.due():
            return
        estimate = self.eta(sim_time)
        eta = "   ?" if estimate is None else f"{estimate:4.0f} s"
        self.line.show(
            f"video {bar(self.cycles_done / max(self.total, 1))} cycle {self.cycles_done}/"
            f"{self.total}  {frames} frames  sim {sim_time:5.1f} s  "
            f"elapsed {self.line.elapsed:4.0f} s  eta {eta}"
        )

    def finish(self, frames: int) -> None:
        """Close the bar with the frame count and the wall time."""
        self.line.end(f"video: {frames} frames in {self.line.elapsed:.1f} s")
