"""util/interrupts: signals as exceptions, remembered for the block they arrived in; held during
the start-up, after the first, and while the outputs are written."""

from __future__ import annotations

import os
import signal
import sys
import time
from collections.abc import Iterator

import pytest

from kr210_sim.util.interrupts import (
    SIGNALS,
    Interrupted,
    check,
    cuttable,
    end_start_up,
    hold_start_up,
    is_the_command,
    received,
    terminate_as_interrupt,
    winding_up,
)


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


def test_after_the_first_signal_the_next_ones_are_held() -> None:
    """A CI cancel signals the process group and ``timeout`` forwards the signal again: the
    second must not cut the report the first one asked for."""
    with terminate_as_interrupt():
        with pytest.raises(Interrupted):
            _sigterm_self()
        os.kill(os.getpid(), signal.SIGINT)
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(0.05)  # handled here, and held: nothing is raised
        assert received() == signal.SIGTERM  # the first decides the exit code
    assert received() is None


def test_a_cuttable_step_is_stopped_by_a_further_signal() -> None:
    with terminate_as_interrupt():
        with pytest.raises(Interrupted):
            _sigterm_self()
        os.kill(os.getpid(), signal.SIGINT)  # held before the step: it does not cut it
        time.sleep(0.05)
        with cuttable():
            time.sleep(0.01)
            with pytest.raises(Interrupted) as caught:
                os.kill(os.getpid(), signal.SIGINT)
                time.sleep(5)
        assert caught.value.signum == signal.SIGINT


@pytest.fixture
def sighup_handled() -> Iterator[None]:
    """SIGHUP at its default action while the test runs: under ``nohup`` (a CI job started so)
    it is ignored, and an ignored signal is left ignored (the next test)."""
    previous = signal.signal(signal.SIGHUP, signal.SIG_DFL)
    try:
        yield
    finally:
        signal.signal(signal.SIGHUP, previous)


def test_a_signal_the_parent_ignored_stays_ignored() -> None:
    previous = signal.signal(signal.SIGHUP, signal.SIG_IGN)  # as ``nohup`` leaves it
    try:
        with terminate_as_interrupt():
            assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN
            os.kill(os.getpid(), signal.SIGHUP)
            time.sleep(0.05)
            assert received() is None
        assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGHUP, previous)


@pytest.mark.usefixtures("sighup_handled")
def test_winding_up_under_the_command_holds_even_a_first_signal() -> None:
    with terminate_as_interrupt():
        with winding_up() as held:
            os.kill(os.getpid(), signal.SIGHUP)
            time.sleep(0.05)
            steps = ["written"]
        assert steps == ["written"] and held == [signal.SIGHUP]
        assert received() == signal.SIGHUP  # it still sets the exit code


def test_winding_up_under_the_python_api_raises_a_first_signal_after_the_block() -> None:
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)  # as in a plain script
    try:
        steps = []
        with pytest.raises(KeyboardInterrupt), winding_up() as held:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.05)
            steps.append("written")
        assert steps == ["written"] and held == [signal.SIGINT]
        stopped = Interrupted(signal.SIGINT)
        with winding_up(stopped) as held:  # the work was already stopped: nothing more raised
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.05)
        assert held == [signal.SIGINT]
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGINT, previous)


def test_the_start_up_holds_signals_until_the_work_begins() -> None:
    before = {s: signal.getsignal(s) for s in SIGNALS}
    hold_start_up()
    with terminate_as_interrupt():  # takes the hold over
        os.kill(os.getpid(), signal.SIGTERM)
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.05)  # imports, parsing: not cut
        with pytest.raises(Interrupted) as caught:
            end_start_up()
        assert caught.value.signum == signal.SIGTERM
        end_start_up()  # once only
    assert {s: signal.getsignal(s) for s in SIGNALS} == before


def test_a_start_up_without_a_signal_ends_quietly() -> None:
    hold_start_up()
    with terminate_as_interrupt():
        end_start_up()
        with pytest.raises(Interrupted):  # from here the first signal raises
            _sigterm_self()


@pytest.mark.parametrize(
    ("orig_argv", "argv0", "expected"),
    [
        (["python", "-m", "kr210_sim", "run"], "-m", True),
        (["python", "-X", "importtime", "-B", "-m", "kr210_sim.__main__"], "-m", True),
        (["python", "-mkr210_sim", "check"], "-m", True),
        (["/venv/bin/python", "/venv/bin/kr210-sim", "run"], "/venv/bin/kr210-sim", True),
        (["python", "-m", "pytest", "-m", "kr210_sim"], "-m", False),
        (["python", "-m", "kr210_sim.sandbox.ik_child", "x"], "-m", False),
        (["python", "-c", "import kr210_sim"], "-c", False),
        (["python", "script.py", "-m", "kr210_sim"], "script.py", False),
    ],
)
def test_is_the_command(
    orig_argv: list[str], argv0: str, expected: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(sys, "orig_argv", orig_argv)
    monkeypatch.setattr(sys, "argv", [argv0])
    assert is_the_command() is expected
