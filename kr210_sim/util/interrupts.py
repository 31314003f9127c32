"""Termination signals handled like Ctrl-C: stop the work, keep what finished, exit 128 + N.

``SIGTERM`` (what ``kill``, ``timeout`` and CI runners send), ``SIGHUP`` (a closed terminal) and
``SIGINT`` (Ctrl-C, ``kill -INT``) raise :class:`Interrupted` in the main thread, a
:class:`KeyboardInterrupt` that carries the signal's number. Every ``except KeyboardInterrupt``
that writes the report of the cycles or episodes finished so far therefore serves all three
signals alike; the exit code tells them
apart (:func:`exit_code`: 130 for Ctrl-C, 143 for SIGTERM, 129 for SIGHUP).

The signal is also remembered (:func:`received`): code that catches everything (a C extension's
import turns the exception into ``ImportError: initialization failed``) cannot make it vanish.
:func:`check` raises it again at a safe point (before a cycle, an episode), and the CLI exits
with the signal's code whatever the command returned.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Callable, Iterator
from types import FrameType

#: Signals turned into :class:`Interrupted` by :func:`terminate_as_interrupt`.
HANDLED = (signal.SIGTERM, signal.SIGHUP)
#: Signals received under :func:`terminate_as_interrupt`, oldest first.
_received: list[int] = []
#: How many :func:`terminate_as_interrupt` blocks are open (they nest); the remembered signals
#: belong to the outermost one and are forgotten when it ends.
_depth = 0


class Interrupted(KeyboardInterrupt):
    """The work was stopped by a signal.

    Args:
        signum: The signal's number (``signal.SIGINT`` for Ctrl-C).
    """

    def __init__(self, signum: int = signal.SIGINT) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = int(signum)


def exit_code(exc: BaseException | None) -> int:
    """The conventional exit code of a process stopped by ``exc``: 128 + the signal's number
    (130 for a plain :class:`KeyboardInterrupt`)."""
    return 128 + int(getattr(exc, "signum", signal.SIGINT))


def signal_name(exc: BaseException | None) -> str:
    """``"SIGINT"``, ``"SIGTERM"``, ... for an interrupt exception."""
    return signal.Signals(int(getattr(exc, "signum", signal.SIGINT))).name


def _raise(signum: int, frame: FrameType | None) -> None:
    _received.append(int(signum))
    raise Interrupted(signum)


def received() -> int | None:
    """The first signal received within :func:`terminate_as_interrupt` (None: none)."""
    return _received[0] if _received else None


def check() -> None:
    """Raise :class:`Interrupted` again for a signal received earlier: at a safe point before
    more work (a cycle, an episode), so that a signal whose exception something swallowed
    still stops the work."""
    signum = received()
    if signum is not None:
        raise Interrupted(signum)


@contextlib.contextmanager
def terminate_as_interrupt() -> Iterator[None]:
    """Within the block, SIGTERM, SIGHUP and SIGINT raise :class:`Interrupted` in the main
    thread, and are remembered (:func:`received`, :func:`check`).

    Outside the main thread (where Python cannot install handlers) this does nothing. The
    previous handlers are restored afterwards; a signal ignored by the parent (``nohup``) stays
    ignored, and a SIGINT handler someone else installed is kept.
    """
    global _depth
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    if _depth == 0:
        _received.clear()
    _depth += 1
    previous = {}
    for sig in (*HANDLED, signal.SIGINT):
        old = signal.getsignal(sig)
        if old is signal.SIG_IGN:
            continue
        if sig == signal.SIGINT and old is not signal.default_int_handler:
            continue
        previous[sig] = old
        signal.signal(sig, _raise)
    try:
        yield
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old)
        _depth -= 1
        if _depth == 0:  # a later run in this process starts with nothing remembered
            _received.clear()


@contextlib.contextmanager
def deferred() -> Iterator[None]:
    """Within the block, Ctrl-C, SIGTERM and SIGHUP are held and acted on when it ends.

    For short steps that must not be cut in half (a message half read from a pipe, a frame
    taken off a queue but not yet written): the interrupt is raised after the step, where the
    state is consistent. Only signals with a Python handler are held; outside the main thread
    this does nothing.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    held: list[int] = []

    def hold(signum: int, frame: FrameType | None) -> None:
        held.append(signum)

    previous: dict[int, Callable[[int, FrameType | None], object]] = {}
    for sig in (signal.SIGINT, *HANDLED):
        old = signal.getsignal(sig)
        if callable(old):
            previous[int(sig)] = old
            signal.signal(sig, hold)
    try:
        yield
    finally:
        for num, handler in previous.items():
            signal.signal(num, handler)
        if held:
            previous[held[0]](held[0], None)  # raises KeyboardInterrupt / Interrupted
