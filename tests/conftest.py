"""Shared test setup.

kr210_sim is imported first, so it picks the GL backend (EGL when there is no display) before any
test module imports mujoco.
"""

from collections.abc import Callable
from typing import Any

import pytest

import kr210_sim  # noqa: F401


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
