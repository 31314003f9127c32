"""A graded student's own time (``grade --timeout``): what its code took, not what others took.

:class:`StudentClock` times the student's IK in its sandbox: the start (its process started and
its module imported) and each call, from the pose sent to the answer back. Our checks, planning
and simulation run between the calls and do not count. Nor does the time its processes were
ready to run but held off the CPU by other processes (a noisy classmate's jail, the grader's own
simulation, any other work on the machine): the sandbox measures it from the kernel's figures
(:mod:`kr210_sim.sandbox.held`) and the clock takes it off. What a student's own processes take
from each other, and its own sleep, still count.

That credit is bounded: before each wait the sandbox's deadline is set to the time left, and the
wait may be moved past it only by the time held, and by at most
:data:`~kr210_sim.sandbox.held.HELD_SHARE` of the budget over the whole student (its wall time
stays within twice ``--timeout``); past that, the wait that uses the budget up is cut where it runs
out (the sandbox then stops the student: ``timeout``).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from kr210_sim.sandbox.held import HELD_SHARE
from kr210_sim.sandbox.ik_sandbox import IkSandbox

FloatArray = npt.NDArray[np.float64]


class StudentClock:
    """The student's IK, timed: the student's own time against its budget (see the module doc).

    Args:
        sandbox: The student's IK in its sandbox (``stop=True``).
        budget: The student's time in all [s].
    """

    def __init__(self, sandbox: IkSandbox, budget: float) -> None:
        self.sandbox = sandbox
        self.budget = budget
        self.import_time = 0.0
        self.call_time = 0.0
        self.calls = 0
        #: Time its processes were held off the CPU by others, not counted [s].
        self.held = 0.0
        #: Wall time of its start and its calls, the held time in it [s].
        self.wall = 0.0

    @property
    def used(self) -> float:
        """The student's time so far [s]."""
        return self.import_time + self.call_time

    @property
    def spent(self) -> bool:
        """Whether the budget is used up (within 1 ms)."""
        return self.used >= self.budget - 1e-3

    def _arm(self) -> float:
        self.sandbox.deadline = time.monotonic() + max(0.0, self.budget - self.used)
        self.sandbox.held_room = max(0.0, HELD_SHARE * self.budget - self.held)
        self.sandbox.held = 0.0
        return time.monotonic()

    def _count(self, t: float) -> float:
        """The student's time of the wait begun at ``t`` (``time.monotonic()``) [s]."""
        wall = time.monotonic() - t
        held = min(self.sandbox.held, wall)
        self.wall += wall
        self.held += held
        return wall - held

    def start(self) -> None:
        """Start the student's process and import its module (see ``IkSandbox.start``)."""
        t = self._arm()
        try:
            self.sandbox.start()
        finally:
            self.import_time += self._count(t)

    def __call__(self, T: FloatArray, q_ref: FloatArray) -> Any:
        """``solve(T, q_ref)`` in the student's process (see ``IkSandbox.__call__``)."""
        self.calls += 1
        t = self._arm()
        try:
            return self.sandbox(T, q_ref)
        finally:
            self.call_time += self._count(t)

    def batch(self, poses: Sequence[FloatArray], q_refs: Sequence[FloatArray] = ()) -> list[Any]:
        """Many poses in one call of the student's process (see ``IkSandbox.batch``)."""
        self.calls += 1
        t = self._arm()
        try:
            return self.sandbox.batch(poses, q_refs)
        finally:
            self.call_time += self._count(t)

    def spent_detail(self) -> str:
        """What used the budget up, one line."""
        if self.calls == 0:
            return f"importing it took longer than --timeout ({self.budget:g} s)"
        held = (
            f"; not counted: {self.held:.1f} s its processes were held off the CPU by others"
            if self.held >= 0.05
            else ""
        )
        return (
            f"its code took longer than --timeout ({self.budget:g} s) in all: "
            f"{self.import_time:.1f} s importing it, {self.call_time:.1f} s in {self.calls} "
            f"calls{held}"
        )
