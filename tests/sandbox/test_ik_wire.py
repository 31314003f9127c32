"""The pipe's frames (sandbox/ik_wire.py): round trips, and what an untrusted writer can send."""

from __future__ import annotations

import os
import struct
import threading
import time

import pytest

from kr210_sim.sandbox.ik_wire import MAX_FRAME, MAX_TEXT, Oversized, receive, send, short


def _pipe_with(data: bytes) -> int:
    """The reading end of a pipe a thread writes ``data`` to (then closes)."""
    r, w = os.pipe()

    def write() -> None:
        with os.fdopen(w, "wb") as f:
            f.write(data)

    threading.Thread(target=write, daemon=True).start()
    return r


def _frame(body: bytes) -> bytes:
    return struct.pack("!I", len(body)) + body


def test_messages_round_trip_in_order() -> None:
    r, w = os.pipe()
    messages = [{"n": i, "q": [0.1 * i] * 6, "text": "é" * i} for i in range(50)]
    writer = threading.Thread(target=lambda: [send(w, m) for m in messages])
    writer.start()
    got = [receive(r, time.monotonic() + 5) for _ in messages]
    writer.join()
    assert got == messages
    os.close(w)
    assert receive(r, time.monotonic() + 5) is None  # end of file
    os.close(r)


def test_an_oversized_frame_is_dropped_and_the_next_one_read() -> None:
    big = _frame(b"x" * (MAX_FRAME + 10))
    r = _pipe_with(big + _frame(b'{"n": 2}'))
    assert receive(r, time.monotonic() + 10) == Oversized(MAX_FRAME + 10)
    assert receive(r, time.monotonic() + 10) == {"n": 2}
    os.close(r)


@pytest.mark.parametrize("body", [b"not json", b"[1, 2]", b'"a string"', b"\xff\xfe"])
def test_a_frame_that_is_not_a_json_object_is_none(body: bytes) -> None:
    r = _pipe_with(_frame(body))
    assert receive(r, time.monotonic() + 5) is None
    os.close(r)


def test_a_frame_cut_short_is_none_and_a_slow_one_times_out() -> None:
    r = _pipe_with(struct.pack("!I", 100) + b'{"n":')
    assert receive(r, time.monotonic() + 5) is None
    os.close(r)
    r, w = os.pipe()
    os.write(w, struct.pack("!I", 100))  # a header, then nothing: the writer stalls
    t0 = time.monotonic()
    with pytest.raises(TimeoutError):
        receive(r, time.monotonic() + 0.2)
    assert time.monotonic() - t0 < 2.0
    os.close(r)
    os.close(w)


def test_short_keeps_short_texts_and_cuts_long_ones_with_a_count() -> None:
    assert short("a  b\n c") == "a b c"
    assert short("x" * MAX_TEXT) == "x" * MAX_TEXT
    cut = short("y" * 10_000_000)
    assert cut == "y" * MAX_TEXT + f" [... {10_000_000 - MAX_TEXT:,} more characters]"
    assert short("z" * 50, limit=10) == "z" * 10 + " [... 40 more characters]"
