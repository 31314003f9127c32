"""Helpers for the evaluation tests that watch real processes (Linux ``/proc``)."""

from __future__ import annotations

import contextlib
import json
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

#: The command line of ``python -m kr210_sim evaluate``.
EVALUATE = [sys.executable, "-m", "kr210_sim", "evaluate"]


@contextlib.contextmanager
def evaluate_process(argv: list[str], **popen: Any) -> Iterator[subprocess.Popen[str]]:
    """``python -m kr210_sim evaluate ARGV`` in its own process, its output piped as text
    (``popen``: more ``subprocess.Popen`` arguments); killed on the way out if still running."""
    proc = subprocess.Popen(
        [*EVALUATE, *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **popen
    )
    try:
        yield proc
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def descendants(pid: int) -> set[int]:
    """The live descendants of ``pid`` (children, their children, ...)."""
    out: set[int] = set()
    todo = [pid]
    while todo:
        p = todo.pop()
        for task in Path(f"/proc/{p}/task").glob("*"):
            try:
                kids = [int(k) for k in (task / "children").read_text().split()]
            except OSError:
                continue
            for k in kids:
                if k not in out:
                    out.add(k)
                    todo.append(k)
    return out


def alive(pid: int) -> bool:
    """Whether ``pid`` is a live process (not gone, not a zombie)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


def cmdline(pid: int) -> str:
    """The command line of ``pid`` ("" when gone)."""
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
    except OSError:
        return ""


def wait_for_records(path: Path, count: int, timeout: float = 180.0) -> int:
    """Wait until the episodes file at ``path`` holds ``count`` records; return how many."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if path.is_file():
            n = len(path.read_text().splitlines()) - 1
            if n >= count:
                return n
        time.sleep(0.1)
    raise TimeoutError(f"{path}: fewer than {count} records after {timeout} s")


def record_count(path: Path) -> int:
    """Complete records in an episodes file (header excluded)."""
    lines = path.read_text().splitlines()[1:]
    return len([json.loads(line) for line in lines])


def left_behind(pids: set[int], grace: float = 5.0) -> list[str]:
    """The processes of ``pids`` still alive after ``grace`` seconds (helpers such as
    multiprocessing's resource tracker exit when they see the driver gone)."""
    deadline = time.monotonic() + grace
    while (live := [p for p in pids if alive(p)]) and time.monotonic() < deadline:
        time.sleep(0.1)
    return [f"{p}: {cmdline(p)}" for p in live]
