"""Processes that go with the one that started them."""

from __future__ import annotations

import contextlib
import os
import signal
import sys

#: ``prctl`` option: the signal this process gets when its parent ends (Linux).
PR_SET_PDEATHSIG = 1


def die_with_parent(parent: int) -> None:
    """Have this process killed (SIGKILL) when its parent ends; exit now when the parent ``parent``
    (a pid) has already ended. Linux only (``PR_SET_PDEATHSIG``); elsewhere nothing is set.

    Args:
        parent: The pid the parent had when it started this process, or 0 when that pid means
            nothing here (a process in a PID namespace of its own sees another): then only the
            death signal is set.
    """
    if not sys.platform.startswith("linux"):
        return
    import ctypes

    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
    if parent > 0 and os.getppid() != parent:  # the parent died before the line above
        os._exit(1)
