"""Console streams that survive a closed pipe or a full device.

``run --cycles 30 | head -1`` closes the pipe after the first line; stdout on a full device
fails every write. Neither is a reason to lose a run: the report is the product, the console
lines are a courtesy. :class:`SafeStream` wraps ``sys.stdout`` / ``sys.stderr`` for the CLI:
the first failed write points the file descriptor at ``/dev/null`` (so the interpreter's own
flush at exit is quiet too), later writes are dropped, and the run goes on; so are writes after
a user's code closed the stream (``sys.stdout.close()``). A broken pipe is
silent (what ``head`` expects); any other write error is said once on stderr.

Text someone else wrote (a student's exception message, its output, a file name) is hostile to
a terminal: an ESC or BEL byte moves the cursor, erases a line, sets the window title or writes
the clipboard (OSC 52), and a bidi override reorders what is shown. :func:`escape` is the one
function that makes such text inert; :class:`EscapingStream` applies it to every write of a
command whose lines quote it, :class:`EscapingFormatter` to every log line.
"""

from __future__ import annotations

import errno
import logging
import os
import sys
from typing import Any, TextIO

#: The line breaks :func:`escape` keeps with ``lines`` (a text's own lines and tabs).
_KEPT_IN_LINES = frozenset("\n\t")


def escape(text: str, lines: bool = False) -> str:
    """``text`` as inert text for a terminal, a log, a JSON reader and a page.

    A file name's undecodable bytes (Python's surrogate escapes) become ``\\xNN``, and every
    character a terminal or a text renderer acts on becomes its Python escape (``\\x1b``,
    ``\\x07``, ``\\x9b``, ``\\r``, ``\\u202e``): C0 and C1 controls, DEL, format
    characters (bidi overrides, zero-width joiners), line and paragraph separators, and every
    other character :meth:`str.isprintable` refuses. What is left is printable; a backslash
    stays as it is (an escape shown is told from a real one by the text around it, never by a
    terminal).

    Args:
        text: Any text, of any origin.
        lines: Keep newlines and tabs (a multi-line text such as captured output); else the
            result is one line.
    """
    try:
        out = text.encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")
    except UnicodeEncodeError:  # a lone surrogate that no byte of a file name gives
        out = text.encode("utf-8", "backslashreplace").decode("utf-8")
    if out.isprintable():
        return out
    return "".join(
        c
        if c.isprintable() or (lines and c in _KEPT_IN_LINES)
        else c.encode("unicode_escape").decode("ascii")
        for c in out
    )


class EscapingStream:
    """A text stream that writes every text :func:`escape`'d, its lines kept: for a command
    whose lines quote what a student or a user's IK wrote (``run --ik``, ``ik-check``).

    Args:
        stream: The stream to wrap.
    """

    def __init__(self, stream: TextIO) -> None:
        self._stream = stream

    def __getattr__(self, attr: str) -> Any:
        return getattr(self._stream, attr)

    def isatty(self) -> bool:
        """False: no terminal to draw on (a redraw's ``\\r`` or a hyperlink's OSC 8 would be
        escaped), so callers write plain lines."""
        return False

    def write(self, text: str) -> int:
        """Write ``text`` escaped (returns the length of ``text``)."""
        self._stream.write(escape(text, lines=True))
        return len(text)


class SafeStream:
    """A text stream whose write errors stop the output, never the program.

    Args:
        stream: The stream to wrap.
        name: Its name for the one-line warning (``"stdout"``).
    """

    def __init__(self, stream: TextIO, name: str) -> None:
        self._stream = stream
        self._name = name
        self.failed: OSError | None = None

    def __getattr__(self, attr: str) -> Any:
        return getattr(self._stream, attr)

    def _fail(self, exc: OSError) -> None:
        self.failed = exc
        try:
            fd = self._stream.fileno()
        except (OSError, ValueError, AttributeError):
            fd = -1
        if fd >= 0:
            devnull = os.open(os.devnull, os.O_WRONLY)
            try:
                os.dup2(devnull, fd)
            finally:
                os.close(devnull)
        if exc.errno != errno.EPIPE and self._name != "stderr":
            err = sys.__stderr__
            try:
                if err is None:
                    return
                err.write(
                    f"kr210_sim: warning: {self._name} cannot be written ({exc.strerror}); "
                    "its output is dropped, reports are still written\n"
                )
                err.flush()
            except (OSError, ValueError, AttributeError):
                pass

    def write(self, text: str) -> int:
        """Write ``text``; after a failure, drop it."""
        if self.failed is not None:
            return len(text)
        try:
            return self._stream.write(text)
        except OSError as exc:
            self._fail(exc)
            return len(text)
        except ValueError:  # the stream was closed (by a user's code): drop the output
            self.failed = OSError(errno.EBADF, "closed")
            return len(text)

    def close(self) -> None:
        """A user's code closing stdout: later output is dropped, the run and its reports go on
        (the interpreter closes the real stream at exit)."""
        self.flush()
        self.failed = self.failed or OSError(errno.EBADF, "closed")

    def flush(self) -> None:
        """Flush; after a failure, do nothing."""
        if self.failed is not None:
            return
        try:
            self._stream.flush()
        except OSError as exc:
            self._fail(exc)
        except ValueError:  # flushed after the stream was closed
            pass

    def isatty(self) -> bool:
        """Whether the wrapped stream is a terminal (False once it failed)."""
        if self.failed is not None:
            return False
        try:
            return bool(self._stream.isatty())
        except (OSError, ValueError):
            return False


class EscapingFormatter(logging.Formatter):
    """A log formatter whose lines are :func:`escape`'d (their newlines kept: a traceback stays
    readable): a log line may quote what a user's IK raised."""

    def format(self, record: logging.LogRecord) -> str:
        """The formatted line, escaped."""
        return escape(super().format(record), lines=True)
