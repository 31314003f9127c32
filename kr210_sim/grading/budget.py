"""A student's time budget (``grade --timeout``, the student's own time): what is tried first,
and how much of the rest fits.

A slow IK (a sympy server of the original exercise takes up to 1.6 s a pose) must still get a
verdict within ``--timeout``, from the cases that mean most, and say how many were tried. The
order:

1. the ``ik_debug`` and ``cell`` cases of ik-check (:data:`FIRST`): the original exercise's
   own checks, and the poses a run needs; all of them, whatever they take;
2. the run, cycle by cycle, each only when what the last one took (before the first, the time
   per pose so far times :data:`CYCLE_POSES`) fits in what is left;
3. the rest of ik-check (zero, singular, limits, random), :data:`CHUNK` cases at a time, as
   long as they fit in what is left and in :data:`REST_SHARE` of the budget.

A phase that stops for time counts what it finished: the cases tried, the cycles run (the pass
bar then applies to those). Nothing here times the student: :class:`~kr210_sim.grading.clock.
StudentClock` does (its own time: not the time others held it off the CPU), and this reads it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Protocol, TypeVar

#: The ik-check groups tried before anything else.
FIRST = ("ik_debug", "cell")
#: ik-check cases asked for at a time (one request of a batch-taking IK).
CHUNK = 16
#: Most of the budget the cases after the run may take (a share of ``--timeout``).
REST_SHARE = 0.25
#: Poses a cycle of the published cell asks the IK for (measured: 101-110; two single poses
#: and three straight lines), for the estimate before the first cycle.
CYCLE_POSES = 110
#: How much more than its estimate a phase is allowed to take before it is not begun.
MARGIN = 1.25

C = TypeVar("C")


class Clock(Protocol):
    """What the budget reads of the student's clock."""

    budget: float
    call_time: float

    @property
    def used(self) -> float:
        """The student's time so far [s]."""
        ...


class Budget:
    """The student's time, read for the decisions of the module doc.

    Args:
        clock: The student's clock (its budget and the time used).
        poses: The poses asked for so far (a callable: the sandbox counts them).
    """

    def __init__(self, clock: Clock, poses: object) -> None:
        self.clock = clock
        self._poses = poses
        self.cut_run = False
        self.cut_cases = False
        self._rest_end: float | None = None

    @property
    def left(self) -> float:
        """The student's time left [s]."""
        return max(0.0, self.clock.budget - self.clock.used)

    def per_pose(self) -> float:
        """The student's time per pose so far [s] (0 before any)."""
        n = int(getattr(self._poses, "poses", 0))
        return self.clock.call_time / n if n else 0.0

    def cycle_fits(self, last: float | None) -> bool:
        """Whether a cycle fits in what is left: ``last`` (what the last cycle took [s]) or,
        before the first, :data:`CYCLE_POSES` poses at the time per pose so far."""
        need = last if last is not None else CYCLE_POSES * self.per_pose()
        fits = need * MARGIN <= self.left
        self.cut_run = self.cut_run or not fits
        return fits

    def rest_fits(self, cases: int) -> int:
        """How many of the next ``cases`` ik-check cases after the run fit (0: stop)."""
        if self._rest_end is None:
            self._rest_end = self.clock.used + REST_SHARE * self.clock.budget
        room = min(self._rest_end, self.clock.budget) - self.clock.used
        per = self.per_pose() * MARGIN
        n = cases if per == 0.0 else int(room // per) if room > 0 else 0
        n = max(0, min(cases, n))
        self.cut_cases = self.cut_cases or n < cases
        return n


def split(cases: Sequence[C], group: object = None) -> tuple[list[C], list[C]]:
    """``cases`` as (the :data:`FIRST` groups' cases, the others), each in its order."""
    first = [c for c in cases if getattr(c, "group", None) in FIRST]
    rest = [c for c in cases if getattr(c, "group", None) not in FIRST]
    return first, rest


def chunks(cases: Sequence[C], size: int = CHUNK) -> list[list[C]]:
    """``cases`` in pieces of at most ``size``."""
    return [list(cases[i : i + size]) for i in range(0, len(cases), size)]


def need_text(budget: Budget) -> str:
    """Why the run was not begun, one phrase: the time a cycle needs at the pace so far."""
    per = budget.per_pose()
    need = math.ceil(CYCLE_POSES * per)
    return (
        f"a cycle asks for about {CYCLE_POSES} poses, {need} s at {per:.2g} s a pose, and "
        f"{budget.left:.0f} s of --timeout were left"
    )
