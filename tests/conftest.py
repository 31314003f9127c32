"""Shared test setup.

kr210_sim is imported first, so it picks the GL backend (EGL when there is no display) before any
test module imports mujoco.
"""

import os
import signal
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

import kr210_sim  # noqa: F401
from kr210_sim.cell.toml import PUBLISHED_CELL
from kr210_sim.sandbox.bwrap import JailUnavailable, find_bwrap

#: The ready pose of :func:`ready_cell` [deg].
READY_Q_DEG = (40, -15, 20, 0, -5, 0)


@pytest.fixture
def ctrl_c_on_call() -> Callable[[Callable[..., Any], int], Callable[..., Any]]:
    """A factory: ``wrap(fn, n)`` behaves like ``fn`` but raises KeyboardInterrupt (as Ctrl-C
    would) on its ``n``-th call. Works for functions and, patched onto a class, for methods."""

    def wrap(fn: Callable[..., Any], n: int) -> Callable[..., Any]:
        calls = 0

        def wrapper(*args: Any, **kwargs: Any) -> Any:
            nonlocal calls
            calls += 1
            if calls == n:
                raise KeyboardInterrupt
            return fn(*args, **kwargs)

        return wrapper

    return wrap


@pytest.fixture
def ready_cell(tmp_path: Path) -> Path:
    """The published cell file with a ready pose of its own, ``[robot] ready_q``
    (:data:`READY_Q_DEG`)."""
    ready = ", ".join(str(v) for v in READY_Q_DEG)
    text = PUBLISHED_CELL.read_text().replace(
        'name = "published"', f'name = "ready"\n[robot]\nready_q = [{ready}]'
    )
    path = tmp_path / "ready.toml"
    path.write_text(text)
    return path


@pytest.fixture(scope="session")
def no_offset_ik(tmp_path_factory: pytest.TempPathFactory) -> str:
    """SPEC of the worked IK example with the exercise's classic mistake: the 0.054 m drop
    between joints 3 and 4 left out of the DH table (a3 = 0)."""
    src = (Path(__file__).resolve().parents[1] / "examples" / "ik_dh.py").read_text()
    assert src.count("\nA3 = -0.054") == 1
    path = tmp_path_factory.mktemp("broken_ik") / "ik_no_offset.py"
    path.write_text(src.replace("\nA3 = -0.054", "\nA3 = 0.0"))
    return f"{path}:solve"


@pytest.fixture(autouse=True)
def _jail_setting_kept(monkeypatch: pytest.MonkeyPatch) -> None:
    """``--no-jail`` sets KR210_JAIL=0 in the process that runs the command (so evaluate's
    workers see it); a test that runs a command in-process must not leave it to the next."""
    import os

    value = os.environ.get("KR210_JAIL")
    monkeypatch.setenv("KR210_JAIL", value or "1")  # what it was comes back after the test
    if value is None:
        monkeypatch.delenv("KR210_JAIL")


#: The signals whose handling a test must leave as it found it.
KEPT_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


@pytest.fixture(autouse=True)
def _signals_kept() -> Iterator[None]:
    """A test that leaves SIGINT, SIGTERM or SIGHUP ignored, handled otherwise or blocked fails,
    and the handling is put back: a process started by a later test in the same worker would
    inherit an ignored signal (and keep it ignored, as a command started under ``nohup`` does),
    so its Ctrl-C would do nothing, far from the test that caused it."""
    handlers = {sig: signal.getsignal(sig) for sig in KEPT_SIGNALS}
    blocked = signal.pthread_sigmask(signal.SIG_BLOCK, [])
    yield
    changed = [
        f"{signal.Signals(sig).name} {handlers[sig]!r} -> {signal.getsignal(sig)!r}"
        for sig in KEPT_SIGNALS
        if signal.getsignal(sig) != handlers[sig]
    ]
    now = signal.pthread_sigmask(signal.SIG_SETMASK, blocked)
    if now != blocked:
        changed.append(f"blocked {sorted(blocked)} -> {sorted(now)}")
    for sig, handler in handlers.items():
        if handler is not None:
            signal.signal(sig, handler)
    if changed:
        pytest.fail("the test left the signals' handling changed: " + "; ".join(changed))


@pytest.fixture(scope="session")
def jail_ok() -> None:
    """Skip where no jail can be made here, unless ``KR210_REQUIRE_JAIL`` is set (CI sets it):
    then the test fails with the reason."""
    try:
        find_bwrap()
    except JailUnavailable as exc:
        if os.environ.get("KR210_REQUIRE_JAIL"):
            raise
        pytest.skip(str(exc))
