"""A CPU hog beside a user's process, for the tests of the time it was held off the CPU
(tests/sandbox/test_held.py, tests/grading/test_clock.py): both on one CPU, the hog outside the
user's process tree, so the user's process waits on that CPU's run queue while the hog runs.

The tests run beside others (``pytest -n``) on a machine that may be shared: whatever else the
kernel puts on the pinned CPU holds the user's process off it too, truly. :class:`Others` measures
how much CPU time that was, from the kernel's per-CPU figures, so a test can bound the time held
by it rather than assume the CPU was free.
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import textwrap
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TypeVar

from kr210_sim.sandbox.procfs import descendants, process_ticks

T = TypeVar("T")

#: A user's ``solve`` that computes for 0.5 s of its own CPU time (the thread's CPU clock, so
#: the machine's load does not change what it costs).
BUSY = textwrap.dedent(
    """
    import time

    def solve(T, q):
        t = time.thread_time()
        while time.thread_time() - t < 0.5:
            pass
        return list(q)
    """
)
#: A user's ``solve`` that sleeps for 0.5 s.
SLEEPY = textwrap.dedent(
    """
    import time

    def solve(T, q):
        time.sleep(0.5)
        return list(q)
    """
)
#: A user's ``solve`` that computes for 0.3 s of CPU time beside three processes of its own
#: that spin for ever (started at its first call): they take its CPU from it.
CROWDED = textwrap.dedent(
    """
    import os, time
    KIDS = []

    def solve(T, q):
        while len(KIDS) < 3:
            pid = os.fork()
            if pid == 0:
                while True:
                    pass
            KIDS.append(pid)
        t = time.thread_time()
        while time.thread_time() - t < 0.3:
            pass
        return list(q)
    """
)


def one_cpu() -> int:
    """The CPU the tests pin to: the last this process may use."""
    return max(os.sched_getaffinity(0))


def pinned(start: Callable[[], T]) -> T:
    """``start()`` run pinned to :func:`one_cpu`: the processes it starts stay there (they
    inherit it); this process is let go again after it."""
    was = os.sched_getaffinity(0)
    os.sched_setaffinity(0, {one_cpu()})
    try:
        return start()
    finally:
        os.sched_setaffinity(0, was)


#: The hog: on one CPU, in a session of its own (so a scheduler's autogroup of its own, which its
#: nice then weighs), at a nice, spinning until killed or for a minute at most.
HOG = """
import os, time
os.setsid()
os.sched_setaffinity(0, {{{cpu}}})
if {nice}:
    try:
        with open("/proc/self/autogroup", "w") as f:
            f.write("{nice}")
    except FileNotFoundError:
        pass
    os.nice({nice})
end = time.monotonic() + 60
while time.monotonic() < end:
    pass
"""


@contextlib.contextmanager
def hog(nice: int = 0) -> Iterator[subprocess.Popen[bytes]]:
    """A process spinning on :func:`one_cpu` at ``nice`` (a negative one needs root: the hog
    then ends at once, and the caller skips) for as long as the block runs."""
    code = HOG.format(cpu=one_cpu(), nice=nice)
    proc = subprocess.Popen([sys.executable, "-c", code], stderr=subprocess.DEVNULL)
    try:
        yield proc
    finally:
        proc.kill()
        proc.wait()


def _cpu_busy(cpu: int) -> float:
    """CPU time ``cpu`` spent on anything but idling since boot [s] (``/proc/stat``)."""
    for line in Path("/proc/stat").read_text().splitlines():
        name, *ticks = line.split()
        if name == f"cpu{cpu}":
            t = [int(x) for x in ticks]
            return (sum(t[:8]) - t[3] - t[4]) / os.sysconf("SC_CLK_TCK")  # less idle, iowait
    raise LookupError(f"cpu{cpu} not in /proc/stat")


def _tree_cpu(root: int) -> float:
    """CPU time of process ``root`` and its live descendants, with the children each reaped [s]
    (:func:`~kr210_sim.sandbox.procfs.process_ticks`)."""
    ticks = process_ticks([root, *descendants(root)])
    return sum(ticks.values()) / os.sysconf("SC_CLK_TCK")


class Others:
    """CPU time that processes other than a tree took on :func:`one_cpu` over a block [s]: the
    CPU's busy time less the tree's CPU time (the tree pinned there), read when the block ends.

    Args:
        root: The tree's first process.
    """

    def __init__(self, root: int) -> None:
        self.root = root
        self.took = 0.0
        self.wall = 0.0

    def __enter__(self) -> Others:
        self._start = (_cpu_busy(one_cpu()), _tree_cpu(self.root), time.monotonic())
        return self

    def __exit__(self, *exc: object) -> None:
        busy, tree, t = self._start
        self.wall = time.monotonic() - t
        grown = (_cpu_busy(one_cpu()) - busy) - (_tree_cpu(self.root) - tree)
        self.took = max(0.0, grown)
