"""A process's output kept bounded: the first and the last part of it and its byte count, read
by a thread of its own (:func:`drain`) so that a process that floods its output never blocks on
a full pipe and never fills the grader's memory."""

from __future__ import annotations

import contextlib
import threading
from typing import IO

#: Bytes of output kept per process: the first and the last half of it.
KEPT_BYTES = 32_768


class Captured:
    """Bounded output of a process: the first and last ``keep // 2`` bytes and the byte count."""

    def __init__(self, keep: int = KEPT_BYTES) -> None:
        self.keep = keep
        self.head = bytearray()
        self.tail = bytearray()
        self.total = 0
        self._lock = threading.Lock()

    def add(self, chunk: bytes) -> None:
        """Take ``chunk`` (read from the process)."""
        half = self.keep // 2
        with self._lock:
            self.total += len(chunk)
            room = half - len(self.head)
            if room > 0:
                self.head += chunk[:room]
                chunk = chunk[room:]
            if chunk:
                self.tail += chunk
                del self.tail[:-half]

    def text(self) -> str:
        """What was kept, with a line saying how much was left out in the middle."""
        with self._lock:
            head, tail = bytes(self.head), bytes(self.tail)
            dropped = self.total - len(head) - len(tail)
        out = head.decode("utf-8", "replace")
        if dropped > 0:
            out += f"\n[... {dropped} bytes left out ...]\n"
        return out + tail.decode("utf-8", "replace")


def drain(stream: IO[bytes], sink: Captured) -> None:
    """Read ``stream`` into ``sink`` until it ends (a thread's target)."""
    with contextlib.suppress(OSError, ValueError):
        while chunk := stream.read1(65536):  # type: ignore[attr-defined]
            sink.add(chunk)
