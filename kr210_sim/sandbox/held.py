"""Time a user's process tree was held off the CPU by other processes, from the kernel's figures.

On a machine shared with other work (a noisy classmate's jail, the grader's own simulation,
anything else), a user's process that is ready to run may wait on the run queue while another
process has the CPU. The kernel counts that wait per task (``/proc/PID/task/TID/schedstat``'s
second field). :func:`held` turns two :class:`Sched` readings of a process tree, taken around a
wait for its answer, into the part of that wait it spent held off the CPU by others:

* the longest run-queue wait of any one of its tasks (one thread that computes the answer and
  waits for a CPU is held for as long as it waits; two that wait at once are not held twice);
* at most the wall time its tasks together did not use the CPU: what a tree's own threads and
  processes take from each other (more runnable than it has CPUs) is its own time, and is not
  held (its CPU time counts, the waits it causes itself do not);
* less the time its control group's CPU quota held it back (a quota's throttling shows to the
  kernel as run-queue wait; at one core, only a tree that runs more than one thing at once is
  throttled, and that is its own doing).

A task that sleeps (``time.sleep``, a blocking read) is not runnable and waits on no run queue,
so a sleeping process is never held. The CPU time is read three ways, each a lower bound, and
the largest taken: the live tasks' own figures (exact), each process's with the threads it ended
and the children it reaped (:func:`~kr210_sim.sandbox.procfs.process_ticks`, in clock ticks),
and the control group's where it keeps one (cgroup v2 ``cpu.stat``'s ``usage_usec``, v1
``cpuacct.usage``). A task that ended before the second reading gives no wait, so is never held.
"""

from __future__ import annotations

import math
import os
import select
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from kr210_sim.sandbox import procfs

#: How much longer than its limit a wait may last for the time the process was held off the CPU,
#: as a share of that limit (a call's time, or a student's whole ``--timeout``): however long it
#: is kept waiting by others, a process is cut at twice its limit.
HELD_SHARE = 1.0
#: A wait shorter than this is not looked into: it is charged whole [s].
HELD_MIN = 0.005
#: The smallest extension of a wait worth waiting for [s].
STEP_MIN = 0.001
#: How far a wait is moved on at a time while the process is ready to run and barely runs [s]:
#: the kernel adds a wait to a task's figures only when the task is run again, so a process
#: kept waiting shows its wait late, and is given this long to show it.
GRACE = 0.05
#: A process is barely running when its tasks together ran less than this share of the time.
STALLED = 0.5


@dataclass(frozen=True, slots=True)
class Sched:
    """What the kernel says of a process tree's CPU at one moment.

    Attributes:
        tasks: Each live task's (CPU time, run-queue wait) since it started [ns], by thread id.
        ticks: Each process's CPU time, its ended threads and reaped children too [clock ticks].
        usage: Its control group's CPU time [ns], or None where none is kept.
        throttled: Time its control group's CPU quota held it back, in all [s] (0: no quota).
        runnable: Its tasks running or ready to run (read only when asked for).
    """

    tasks: dict[int, tuple[int, int]] = field(default_factory=dict)
    ticks: dict[int, int] = field(default_factory=dict)
    usage: int | None = None
    throttled: float = 0.0
    runnable: frozenset[int] = frozenset()


def read(
    pids: list[int], usage: int | None = None, throttled: float = 0.0, states: bool = False
) -> Sched:
    """A reading of processes ``pids`` (with their control group's ``usage`` [ns] and
    ``throttled`` time [s], where the caller has them; with ``states``, which tasks are
    runnable)."""
    ready = procfs.runnable(pids) if states else frozenset()
    return Sched(procfs.task_times(pids), procfs.process_ticks(pids), usage, throttled, ready)


def _grown(now: int, then: int | None) -> int:
    """What a counter grew by: ``now`` less ``then``, or ``now`` whole when ``then`` is missing
    or larger (a new task or process that took an ended one's id)."""
    return now if then is None or now < then else now - then


def cpu_between(before: Sched, after: Sched) -> float:
    """CPU time the tree used between two readings, the largest of the lower bounds of the
    module doc [s]."""
    tasks = sum(
        _grown(run, before.tasks.get(tid, (None, None))[0]) for tid, (run, _) in after.tasks.items()
    )
    ticks = sum(_grown(t, before.ticks.get(pid)) for pid, t in after.ticks.items())
    group = 0
    if after.usage is not None and before.usage is not None:
        group = max(0, after.usage - before.usage)
    return max(tasks / 1e9, ticks / os.sysconf("SC_CLK_TCK"), group / 1e9)


def waited_between(before: Sched, after: Sched) -> float:
    """The longest run-queue wait of one live task between two readings [s]."""
    waits = (
        _grown(w, before.tasks.get(tid, (None, None))[1]) for tid, (_, w) in after.tasks.items()
    )
    return max(waits, default=0) / 1e9


def held(before: Sched, after: Sched, wall: float) -> float:
    """The time a tree was held off the CPU by other processes between two readings taken
    ``wall`` seconds apart (see the module doc) [s]: 0 at least, ``wall`` at most."""
    own = cpu_between(before, after) + max(0.0, after.throttled - before.throttled)
    return max(0.0, min(waited_between(before, after), wall - own, wall))


class Meter:
    """The time held off the CPU during one wait for a process tree's answer, read as it goes.

    The first reading is taken :data:`HELD_MIN` into the wait (none for an answer that came
    sooner: most do, and reading costs about as much as such a call); the time held is counted
    from there.

    Args:
        read: A reading of the tree now (:func:`read`; ``fresh``: look for its processes again,
            else those found last may do), or None where nothing can be read.
        cap: Most time the wait may be credited as held [s].
        new: The tree is started only now (the first reading is of no process, at the start).
    """

    def __init__(self, read: Callable[[bool], Sched | None], cap: float, new: bool = False) -> None:
        self._read = read
        self.cap = max(0.0, cap)
        self.start = time.monotonic()
        self._before = Sched() if new and self.cap > 0 else None
        self._since = self.start
        self._last = (self.start, self._before)
        #: The held time at the last look [s].
        self.held = 0.0
        #: At the last look, some task was ready to run but the tree barely ran since the
        #: look before (:data:`STALLED`): kept waiting, its wait not yet in its figures.
        self.stalled = False

    def _begin(self) -> None:
        """The first reading, if there is to be one and it is not taken yet."""
        if self._before is None and self.cap > 0:
            self._since = time.monotonic()
            self._before = self._read(False)
            self._last = (self._since, self._before)

    def look(self) -> float:
        """The time held so far, at most :attr:`cap` [s] (kept in :attr:`held`)."""
        now = time.monotonic()
        if self._before is None or now - self._since < HELD_MIN:
            return self.held
        after = self._read(True)
        if after is not None:
            wall = now - self._since
            self.held = max(self.held, min(self.cap, held(self._before, after, wall)))
            then, last = self._last
            if last is not None:
                ran = cpu_between(last, after)
                self.stalled = bool(after.runnable) and ran < STALLED * (now - then)
            self._last = (now, after)
        return self.held

    def ready(self, fd: int, until: float | None) -> float | None:
        """Wait for ``fd`` to be readable up to ``until`` (``time.monotonic()``; None: for
        ever), moved on by the time held as it grows; the ``until`` to read the answer by."""
        if until is None:
            return None
        first = min(until, self.start + HELD_MIN) - time.monotonic()
        if first > 0 and select.select([fd], [], [], first)[0]:
            return until
        self._begin()
        end = until
        while True:
            left = end - time.monotonic()
            if left > 0 and select.select([fd], [], [], left)[0]:
                return end
            later = until + self.look()
            now = time.monotonic()
            if self.stalled:
                later = max(later, min(now + GRACE, until + self.cap))
            if math.isnan(later) or later - now < STEP_MIN:
                return end
            end = later
