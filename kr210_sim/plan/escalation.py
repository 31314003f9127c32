"""Escalating OMPL searches: a move is ``no_path`` only when a fixed schedule of searches fails.

One search with a fixed budget turns a hard move into a wrong verdict: the column cell with its
pillar at (1.6, 1.6) had its slot 6 approach refused after 30,000 validity checks, and found
with other random numbers or more checks. :func:`escalate` runs the searches of a schedule in
order and stops at the first that gives a path:

- the first attempt is the single search of before (RRTConnect, the seed drawn from the plan's
  own ends, :data:`~kr210_sim.plan.sampling_planner.SOLVE_CHECKS`), so a move that it solves
  is planned as before, at its cost: easy moves do not pay for the escalation;
- then restarts with new seeds, each drawn from the same ends and the attempt's number
  (:func:`~kr210_sim.plan.sampling_planner.plan_seed`), with growing budgets;
- then another planner, OMPL's RRT (one tree grown from the start towards goal-biased samples,
  a different exploration from RRTConnect's two trees), with the largest budget.

The budgets of :data:`SCHEDULE` add up to ten times the single search's. Every attempt depends
on nothing but the move (its ends, rounded as the seeds are, and the hold): ``check`` and
``run`` escalate alike and come to the same verdict, and reports stay deterministic.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Generic, TypeVar

from kr210_sim.errors import NoPathError, PlanningError
from kr210_sim.plan.sampling_planner import PLANNERS, SOLVE_CHECKS

T = TypeVar("T")


@dataclass(frozen=True, slots=True)
class Attempt:
    """One search of an escalation.

    Attributes:
        planner: The OMPL geometric planner (one of
            :data:`~kr210_sim.plan.sampling_planner.PLANNERS`).
        seed: Which seed of the move's ends to draw (0: the first, as a single search draws).
        checks: Most validity checks of each search the attempt makes.
    """

    planner: str
    seed: int
    checks: int

    def __post_init__(self) -> None:
        if self.planner not in PLANNERS:
            raise ValueError(f"unknown OMPL planner {self.planner!r}: one of {sorted(PLANNERS)}")
        if self.seed < 0 or self.checks <= 0:
            raise ValueError(f"an attempt needs a seed >= 0 and checks > 0, not {self}")


#: The searches tried in turn before a move is ``no_path``: today's single search, three
#: restarts with new seeds and growing budgets, then RRT; 300,000 checks in all, ten times the
#: single search's 30,000.
SCHEDULE: tuple[Attempt, ...] = (
    Attempt("RRTConnect", 0, SOLVE_CHECKS),
    Attempt("RRTConnect", 1, SOLVE_CHECKS),
    Attempt("RRTConnect", 2, 2 * SOLVE_CHECKS),
    Attempt("RRTConnect", 3, 2 * SOLVE_CHECKS),
    Attempt("RRT", 4, 4 * SOLVE_CHECKS),
)


def budget(schedule: Sequence[Attempt]) -> int:
    """The validity checks a schedule's searches may make in all (each attempt counted once)."""
    return sum(a.checks for a in schedule)


def describe(schedule: Sequence[Attempt]) -> str:
    """The schedule in words, e.g. "RRTConnect seeds 0-3, then RRT seed 4"."""
    parts: list[tuple[str, list[int]]] = []
    for a in schedule:
        if parts and parts[-1][0] == a.planner:
            parts[-1][1].append(a.seed)
        else:
            parts.append((a.planner, [a.seed]))
    words = []
    for planner, seeds in parts:
        contiguous = seeds == list(range(seeds[0], seeds[0] + len(seeds)))
        if len(seeds) == 1:
            words.append(f"{planner} seed {seeds[0]}")
        elif contiguous:
            words.append(f"{planner} seeds {seeds[0]}-{seeds[-1]}")
        else:
            words.append(f"{planner} seeds {', '.join(map(str, seeds))}")
    return ", then ".join(words)


@dataclass(frozen=True, slots=True)
class Escalated(Generic[T]):
    """The result of :func:`escalate`.

    Attributes:
        result: What the first successful attempt gave.
        attempt: Its index in the schedule (0: the first search succeeded).
        checks: Validity checks made by all attempts tried.
    """

    result: T
    attempt: int
    checks: int


def escalate(
    search: Callable[[Attempt], T],
    checks: Callable[[], int],
    schedule: Sequence[Attempt] = SCHEDULE,
) -> Escalated[T]:
    """Run ``search`` on each attempt of ``schedule`` in turn until one succeeds.

    Args:
        search: Plans the move with one attempt; raises :class:`NoPathError` (no path within
            the attempt's budget) or :class:`PlanningError` (a path found but refused, e.g. its
            timed samples collide) when the attempt fails.
        checks: The validity checks made so far (a counter that only grows).
        schedule: The attempts, in order.

    Returns:
        The first attempt's result, with its index and the checks of every attempt tried.

    Raises:
        NoPathError: When every attempt fails: how many searches, which, the validity checks
            they made in all, and why the last one failed.
    """
    if not schedule:
        raise ValueError("an escalation needs at least one attempt")
    c0 = checks()
    last: PlanningError | None = None
    for i, attempt in enumerate(schedule):
        try:
            return Escalated(search(attempt), i, checks() - c0)
        except PlanningError as exc:  # NoPathError is a PlanningError
            last = exc
    n = len(schedule)
    raise NoPathError(
        f"OMPL found no collision-free path in {n} search{'es' if n > 1 else ''} "
        f"({describe(schedule)}; {budget(schedule)} validity checks allowed), "
        f"{checks() - c0} validity checks in all; the last: {last}"
    ) from last
