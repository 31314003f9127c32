"""util/interrupts: signals as exceptions, remembered for the block they arrived in."""

from __future__ import annotations

import os
import signal
import time

import pytest

from kr210_sim.util.interrupts import Interrupted, check, received, terminate_as_interrupt


def _sigterm_self() -> None:
    os.kill(os.getpid(), signal.SIGTERM)
    time.sleep(5)  # the handler raises long before this ends


def test_a_signal_is_remembered_in_its_block_and_forgotten_after_it() -> None:
    with terminate_as_interrupt():
        with pytest.raises(Interrupted):
            _sigterm_self()
        assert received() == signal.SIGTERM
        with pytest.raises(Interrupted):
            check()  # swallowed once, it still stops the next piece of work
    # A later run in the same process (the Python API, a test) starts with nothing pending.
    assert received() is None
    check()


def test_nested_blocks_keep_the_outer_blocks_signal() -> None:
    with terminate_as_interrupt():
        with pytest.raises(Interrupted), terminate_as_interrupt():
            _sigterm_self()
        assert received() == signal.SIGTERM
    assert received() is None
