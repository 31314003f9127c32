"""The pipe between the grader's side and a user's IK process: length-prefixed JSON frames.

A frame is a 4-byte big-endian length and that many bytes of JSON holding one object. Both sides
speak it (:mod:`kr210_sim.sandbox.ik_sandbox` and :mod:`kr210_sim.sandbox.ik_child`); the grader's
side is on guard both ways. The user's process may stop reading its requests, so :func:`send` takes
a deadline; it may write anything to its end of the pipe, so :func:`receive` bounds a frame's size
(:data:`MAX_FRAME`) and the time it may take, and tells a frame that is too big (:class:`Oversized`)
and one that is not a JSON object (:class:`Malformed`: not JSON, nested past the decoder's depth,
an integer past Python's digits) from the end of the pipe (None). :func:`answer_of` reads an
answer's message back into the answer (numbers, None, the exception the user's code raised, or an
unusable answer that says what it was: :func:`refusal`).
"""

from __future__ import annotations

import json
import os
import select
import struct
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from kr210_sim.errors import one_line

_HEADER = struct.Struct("!I")
#: Largest frame either side reads [bytes]: six angles need about 150.
MAX_FRAME = 1 << 20
#: Largest text a message carries (an exception's message, why an answer is not six numbers)
#: [characters]; the rest is cut, with a note of how much.
MAX_TEXT = 2_000


@dataclass(frozen=True, slots=True)
class Oversized:
    """A frame larger than :data:`MAX_FRAME` (read and thrown away).

    Attributes:
        size: The length its header gave [bytes].
    """

    size: int


@dataclass(frozen=True, slots=True)
class Malformed:
    """A frame that is not one JSON object: the user's code wrote to the pipe itself.

    Attributes:
        size: Its length [bytes].
        why: What the decoder said of it, one line.
    """

    size: int
    why: str


def send(fd: int, message: dict[str, Any], deadline: float | None = None) -> None:
    """Write ``message`` as one frame to ``fd``.

    The reader may be the user's process, which can shrink its pipe to one page and stop
    reading: with a ``deadline`` (``time.monotonic()``) the write waits for room only until
    then, without ever blocking in ``os.write``, and raises TimeoutError past it (None: block
    until it is all written, for the user's side, which writes to the grader).

    Raises:
        TimeoutError: The frame was not all written before ``deadline``.
        OSError: The pipe is closed (the reader is gone).
    """
    data = json.dumps(message).encode()
    view = memoryview(_HEADER.pack(len(data)) + data)
    if deadline is None:
        while view:
            view = view[os.write(fd, view) :]
        return
    blocking = os.get_blocking(fd)
    os.set_blocking(fd, False)
    try:
        while view:
            try:
                view = view[os.write(fd, view) :]
                continue
            except BlockingIOError:
                pass
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([], [fd], [], left)[1]:
                raise TimeoutError
    finally:
        os.set_blocking(fd, blocking)


def read_exact(fd: int, n: int, deadline: float | None) -> bytes | None:
    """``n`` bytes from ``fd``; None at end of file; TimeoutError past ``deadline``
    (``time.monotonic()``; None: wait for ever)."""
    buf = bytearray()
    while len(buf) < n:
        if deadline is not None:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([fd], [], [], left)[0]:
                raise TimeoutError
        chunk = os.read(fd, min(n - len(buf), 1 << 20))
        if not chunk:
            return None
        buf += chunk
    return bytes(buf)


def _discard(fd: int, n: int, deadline: float | None) -> bool:
    """Read and drop ``n`` bytes; False at end of file. TimeoutError past ``deadline``."""
    while n > 0:
        chunk = read_exact(fd, min(n, 1 << 20), deadline)
        if chunk is None:
            return False
        n -= len(chunk)
    return True


def receive(fd: int, deadline: float | None) -> dict[str, Any] | Oversized | Malformed | None:
    """One message from ``fd``.

    Returns:
        The message; :class:`Oversized` for a frame over :data:`MAX_FRAME` (its bytes read and
        dropped, so the next frame can be read); :class:`Malformed` for a frame that is not a
        JSON object; None at end of file.

    Raises:
        TimeoutError: The frame did not arrive whole before ``deadline``.
    """
    head = read_exact(fd, _HEADER.size, deadline)
    if head is None:
        return None
    (size,) = _HEADER.unpack(head)
    if size > MAX_FRAME:
        return Oversized(size) if _discard(fd, size, deadline) else None
    body = read_exact(fd, size, deadline)
    if body is None:
        return None
    try:
        message = json.loads(body)
    except (ValueError, RecursionError) as exc:  # RecursionError: nested past the decoder
        return Malformed(size, short(str(exc), 200))
    if not isinstance(message, dict):
        return Malformed(size, f"a JSON {type(message).__name__}, not an object")
    return message


def short(text: str, limit: int = MAX_TEXT) -> str:
    """``text`` as one line (:func:`~kr210_sim.errors.one_line`), cut to ``limit`` characters
    with a note of how many were left out."""
    head = text[: 4 * limit]  # white space aside, no more is needed: a huge text stays cheap
    flat = one_line(head)
    if len(head) == len(text) and len(flat) <= limit:
        return flat
    return f"{flat[:limit]} [... {len(text) - limit:,} more characters]"


def refusal(what: str, why: str) -> Any:
    """An object standing for an answer that is not numbers: named ``what``, and converting it
    (``float``, ``numpy.asarray``) raises ``TypeError(why)``, which the guard reports."""

    def refuse(*args: object, **kwargs: object) -> None:
        raise TypeError(why)

    return type(what, (), {"__array__": refuse, "__float__": refuse})()


def oversized(size: int) -> Any:
    """The unusable answer that stands for a message of ``size`` bytes, over the bound."""
    return refusal(
        f"an answer of {size:,} bytes",
        f"a message may hold at most {MAX_FRAME:,} bytes; six angles take about 150",
    )


def answer_of(message: dict[str, Any]) -> Any:
    """The user's answer from its message (see :func:`kr210_sim.sandbox.ik_child.reply`)."""
    if "raised" in message:
        name = short(str(message["raised"]), 200).replace("\x00", "\\x00")
        kind = type(name or "Exception", (Exception,), {})  # a type's name holds no NUL
        raise kind(str(message.get("message", "")))
    if message.get("none"):
        return None
    if "q" in message:
        try:  # what the user's process sent: a list of numbers and its shape, or so it says
            q = np.asarray(message["q"], dtype=np.float64)
            return q.reshape(tuple(int(n) for n in message.get("shape", q.shape)))
        except (TypeError, ValueError, OverflowError) as exc:
            return refusal(
                "a malformed answer", f"the answer's message does not hold numbers: {exc}"
            )
    return refusal(str(message.get("object", "object")), str(message.get("why", "")))
