"""Termination signals handled like Ctrl-C: stop the work, keep what finished, exit 128 + N.

``SIGTERM`` (what ``kill``, ``timeout`` and CI runners send), ``SIGHUP`` (a closed terminal) and
``SIGINT`` (Ctrl-C, ``kill -INT``) raise :class:`Interrupted` in the main thread, a
:class:`KeyboardInterrupt` that carries the signal's number. Every ``except KeyboardInterrupt``
that writes the report of the cycles or episodes finished so far therefore serves all three
signals alike; the exit code tells them apart (:func:`exit_code`: 130 for Ctrl-C, 143 for
SIGTERM, 129 for SIGHUP).

A command's life, as :func:`terminate_as_interrupt` and the functions below see it:

- **Start-up** (:func:`hold_start_up`, from the package's first module on when the process is the
  command: :func:`is_the_command`). Imports and the parsing of the arguments are not cut: a
  signal is held (remembered) and raised by :func:`end_start_up` where the command's work
  begins, inside its own handling of an interrupt (``run`` writes its report of no cycles). An
  exception raised inside the import of a C extension, or in ``runpy``'s import of the
  package, could not be caught cleanly. A start-up that has not ended
  :data:`START_UP_GRACE_S` seconds after the signal is ended there (one line, exit 128 + N).
- **Work.** The first signal raises :class:`Interrupted`. It is also remembered
  (:func:`received`): code that catches everything (a C extension's import turns the exception
  into ``ImportError: initialization failed``) cannot make it vanish. :func:`check` raises it
  again at a safe point (before a cycle, an episode), and the CLI exits with the signal's code
  whatever the command returned.
- **Winding up.** Every signal after the first is held: remembered, never raised, so the report
  of what was done is written whole however many signals follow (a CI cancel signals the
  process group, and ``timeout`` forwards the signal again: two signals a few ms apart).
  :func:`winding_up` holds them for a block of its own (the outputs of a run that ended,
  also under the Python API); a :func:`cuttable` step within it (rendering a video's last
  frames) is the one a further signal still stops. :func:`deferred` holds them for a short
  step that must not be cut in half.
- **Exit** (:func:`leaving`): the exit code is decided; a signal ends the process at once with it.
"""

from __future__ import annotations

import atexit
import contextlib
import os
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from types import FrameType
from typing import Any

#: Signals turned into :class:`Interrupted` by :func:`terminate_as_interrupt`.
HANDLED = (signal.SIGTERM, signal.SIGHUP)
#: Every signal this module handles.
SIGNALS = (signal.SIGINT, *HANDLED)
#: Seconds a start-up may go on after a signal before the process is ended where it stands.
START_UP_GRACE_S = 10.0
#: The module names ``python -m`` runs the command with.
COMMAND_MODULES = frozenset({"kr210_sim", "kr210_sim.__main__"})
#: The console script's name.
COMMAND_SCRIPT = "kr210-sim"

#: Signals received under :func:`terminate_as_interrupt` (or during the start-up), oldest first.
_received: list[int] = []
#: How many :func:`terminate_as_interrupt` blocks are open (they nest); the remembered signals
#: belong to the outermost one and are forgotten when it ends.
_depth = 0
#: Holds open: the start-up's, :func:`winding_up` blocks, the one :func:`work_done` opens.
_holding = 0
#: :func:`cuttable` blocks open.
_cuttable = 0
#: The start-up hold: the handlers found before it, the grace timer, the decided exit code.
_start: dict[str, Any] = {"on": False, "saved": {}, "timer": None, "leaving": None}


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


def _on_signal(signum: int, frame: FrameType | None) -> None:
    """The handler: remember the signal; raise it if it is the first and nothing holds it, or in
    a :func:`cuttable` step."""
    first = not _received
    _received.append(int(signum))
    if _start["on"] and _start["timer"] is None:
        timer = threading.Timer(START_UP_GRACE_S, _give_up, (int(signum),))
        timer.daemon = True
        _start["timer"] = timer
        timer.start()
    if _cuttable or (first and not _holding):
        raise Interrupted(signum)


def _give_up(signum: int) -> None:
    """The grace timer: the start-up did not end after a signal; end the process here."""
    line = (
        f"kr210_sim: interrupted ({signal.Signals(signum).name}) during start-up, which had not "
        f"ended {START_UP_GRACE_S:g} s later; stopped there, nothing written\n"
    )
    os.write(2, line.encode())
    os._exit(128 + signum)


def _exit_now(signum: int, frame: FrameType | None) -> None:
    """After :func:`leaving`: the exit code is decided, a signal only makes it happen now."""
    os._exit(_start["leaving"])


def _install(handler: Callable[[int, FrameType | None], Any]) -> dict[int, Any]:
    """Put ``handler`` on the signals this module handles; return the handlers it replaced.

    A signal ignored by the parent (``nohup``, a background job's SIGINT) stays ignored, and a
    SIGINT handler someone else installed is kept."""
    previous: dict[int, Any] = {}
    for sig in SIGNALS:
        old = signal.getsignal(sig)
        if old is signal.SIG_IGN:
            continue
        if sig == signal.SIGINT and old not in (signal.default_int_handler, _on_signal):
            continue
        previous[int(sig)] = old
        signal.signal(sig, handler)
    return previous


def _replace_python_handlers(
    handler: Callable[[int, FrameType | None], Any],
) -> dict[int, Callable[[int, FrameType | None], Any]]:
    """Put ``handler`` in place of the Python handlers of the signals this module handles (the
    default actions stay); return those it replaced."""
    previous = {}
    for sig in SIGNALS:
        old = signal.getsignal(sig)
        if callable(old):
            previous[int(sig)] = old
            signal.signal(sig, handler)
    return previous


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


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


def is_the_command() -> bool:
    """Whether this process is the ``kr210_sim`` command (``python [options] -m kr210_sim``,
    or the ``kr210-sim`` script), not a program that imports the package."""
    argv = list(getattr(sys, "orig_argv", []))
    takes_value = {"-X", "-W", "--check-hash-based-pycs"}
    i = 1
    while i < len(argv):
        arg = argv[i]
        if arg == "-m":
            return i + 1 < len(argv) and argv[i + 1] in COMMAND_MODULES
        if arg.startswith("-m"):
            return arg[2:] in COMMAND_MODULES
        if arg in takes_value:
            i += 2
            continue
        if not arg.startswith("-") or arg == "-c":
            break
        i += 1
    return bool(sys.argv) and Path(sys.argv[0]).name == COMMAND_SCRIPT


def hold_start_up() -> None:
    """Hold SIGINT, SIGTERM and SIGHUP from now until :func:`end_start_up`: the command's first
    act (its imports and the parsing of its arguments are not cut; the signals are remembered).

    :func:`terminate_as_interrupt` takes the hold over and ends it if nothing did before. Does
    nothing outside the main thread or when a hold or a block is already open.
    """
    if _start["on"] or _depth or not _main_thread():
        return
    _received.clear()
    _start["saved"] = _install(_on_signal)
    _start["on"] = True
    _hold(+1)


def end_start_up() -> None:
    """End the start-up's hold where the command's work begins, inside its own handling of an
    interrupt: a signal held during the start-up is raised here.

    Raises:
        Interrupted: For the first signal held since :func:`hold_start_up`.
    """
    if not _start["on"]:
        return
    _start["on"] = False
    _hold(-1)
    timer = _start["timer"]
    if timer is not None:
        timer.cancel()
        _start["timer"] = None
    if _received:
        raise Interrupted(_received[0])


def work_done() -> None:
    """The command's work is over: hold every signal from now until its block ends (they still
    set the exit code, :func:`received`)."""
    if _depth:
        _hold(+1)


def leaving(code: int) -> None:
    """The command has decided its exit ``code``: once the outermost
    :func:`terminate_as_interrupt` ends, a signal ends the process at once with it (the
    interpreter's shutdown is not cut by a KeyboardInterrupt into a death by signal)."""
    _start["leaving"] = int(code)


def _hold(step: int) -> None:
    global _holding
    _holding += step


@contextlib.contextmanager
def terminate_as_interrupt() -> Iterator[None]:
    """Within the block, SIGTERM, SIGHUP and SIGINT raise :class:`Interrupted` in the main
    thread, and are remembered (:func:`received`, :func:`check`); see the module's text for
    the signals after the first.

    The outermost block takes over the start-up's hold (:func:`hold_start_up`), with the
    signals it held. Outside the main thread (where Python cannot install handlers) this does
    nothing. The previous handlers are restored afterwards (after :func:`leaving`: a signal ends
    the process with the code decided); a signal ignored by the parent (``nohup``) stays
    ignored, and a SIGINT handler someone else installed is kept.
    """
    global _depth
    if not _main_thread():
        yield
        return
    outermost = _depth == 0
    if outermost and _start["on"]:
        previous = dict(_start["saved"])
    else:
        if outermost:
            _received.clear()
        previous = _install(_on_signal)
    _depth += 1
    try:
        yield
    finally:
        _depth -= 1
        if outermost:
            _reset(previous)
        else:
            for sig, old in previous.items():
                signal.signal(sig, old)


def _reset(previous: dict[int, Any]) -> None:
    """The outermost block ends: no hold, nothing remembered (a later run in this process, the
    Python API or a test, starts afresh), the handlers as they were, or :func:`_exit_now`."""
    global _holding, _cuttable
    timer = _start["timer"]
    if timer is not None:
        timer.cancel()
    _start.update(on=False, saved={}, timer=None)
    _holding = _cuttable = 0
    _received.clear()
    leaving_code = _start["leaving"]
    for sig, old in previous.items():
        signal.signal(sig, old if leaving_code is None else _exit_now)


@contextlib.contextmanager
def winding_up(stopped_by: BaseException | None = None) -> Iterator[list[int]]:
    """Write the outputs of the work done, whole: within the block SIGINT, SIGTERM and SIGHUP are
    held, except in a :func:`cuttable` step.

    Args:
        stopped_by: The interrupt that stopped the work, None when it ran to its end.

    Yields:
        A list that holds, once the block has ended, the signals it held (oldest first).

    Under :func:`terminate_as_interrupt` nothing is raised after the block either: the signals
    are remembered and set the exit code (:func:`received`). Under the Python API (no such
    block), the first signal held is raised when the block ends, unless ``stopped_by`` shows
    the work was already stopped. Outside the main thread this holds nothing.
    """
    held: list[int] = []
    if not _main_thread():
        yield held
        return
    if _depth:
        mark = len(_received)
        _hold(+1)
        try:
            yield held
        finally:
            _hold(-1)
            held.extend(_received[mark:])
        return

    def hold(signum: int, frame: FrameType | None) -> None:
        if _cuttable:
            raise Interrupted(signum)
        held.append(signum)

    previous = _replace_python_handlers(hold)
    try:
        yield held
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old)
    if held and stopped_by is None:
        previous[held[0]](held[0], None)  # raises KeyboardInterrupt / Interrupted


@contextlib.contextmanager
def cuttable() -> Iterator[None]:
    """A long step of a wind-up that a further signal may cut short (a video's last frames
    rendered): within the block a signal raises :class:`Interrupted`, even after the first.
    The signals held before the block do not cut it."""
    global _cuttable
    _cuttable += 1
    try:
        yield
    finally:
        _cuttable -= 1


@contextlib.contextmanager
def deferred() -> Iterator[None]:
    """Within the block, Ctrl-C, SIGTERM and SIGHUP are held and acted on when it ends.

    For short steps that must not be cut in half (a message half read from a pipe, a frame
    taken off a queue but not yet written): the interrupt is raised after the step, where the
    state is consistent (or held on, after the first signal: see the module's text). Only
    signals with a Python handler are held; outside the main thread this does nothing.
    """
    if not _main_thread():
        yield
        return
    held: list[int] = []

    def hold(signum: int, frame: FrameType | None) -> None:
        held.append(signum)

    previous = _replace_python_handlers(hold)
    try:
        yield
    finally:
        for num, handler in previous.items():
            signal.signal(num, handler)
        if held:
            previous[held[0]](held[0], None)  # raises KeyboardInterrupt / Interrupted


def _ignore_at_exit() -> None:
    """The last of the command's exit handlers: Python puts the default actions back as it
    shuts down, so a signal after the decided exit would end the process by signal; ignore
    the signals for the rest of the shutdown."""
    if _start["leaving"] is not None:
        for sig in SIGNALS:
            if signal.getsignal(sig) is _exit_now:
                signal.signal(sig, signal.SIG_IGN)


if is_the_command():  # the command's first module: hold the signals before the heavy imports
    hold_start_up()
    atexit.register(_ignore_at_exit)  # registered first, so run last
