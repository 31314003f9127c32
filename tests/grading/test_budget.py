"""A student's time budget (grading/budget.py): the first cases, then cycles while one fits, then
the rest within its share."""

from __future__ import annotations

from dataclasses import dataclass

from kr210_sim.grading.budget import CHUNK, CYCLE_POSES, MARGIN, REST_SHARE, Budget, chunks, split
from kr210_sim.grading.ikcheck import fixed_cases, random_cases
from kr210_sim.robot import kinematics


@dataclass
class Clock:
    """The figures a StudentClock keeps: its budget and the time used."""

    budget: float
    call_time: float = 0.0
    import_time: float = 0.0

    @property
    def used(self) -> float:
        return self.import_time + self.call_time


@dataclass
class Sandbox:
    poses: int = 0


def test_the_exercises_own_cases_come_first() -> None:
    kin = kinematics.committed()
    cases = fixed_cases(kin) + random_cases(kin, 40, 1)
    first, rest = split(cases)
    assert {c.group for c in first} == {"ik_debug", "cell"}
    assert first[0].name == "IK_debug case 1" and len(first) + len(rest) == len(cases)
    assert [c.name for c in first + rest] == [c.name for c in cases]  # the order kept
    assert [len(c) for c in chunks(rest)] == [CHUNK] * (len(rest) // CHUNK) + [len(rest) % CHUNK]


def test_a_slow_student_runs_what_fits() -> None:
    """1 s a pose: after the 48 first cases (48 s of 120), a cycle (110 poses) does not fit;
    the rest gets its share of the budget; a fast student gets everything."""
    clock, box = Clock(budget=120.0, call_time=48.0), Sandbox(poses=48)
    budget = Budget(clock, box)
    assert budget.per_pose() == 1.0 and budget.left == 72.0
    assert not budget.cycle_fits(None) and budget.cut_run
    assert budget.rest_fits(16) == 16 and not budget.cut_cases  # room for 24
    clock.call_time += 16.0
    box.poses += 16
    assert budget.rest_fits(16) == int((REST_SHARE * 120 - 16) / MARGIN) == 11
    assert budget.cut_cases
    fast = Budget(Clock(budget=120.0, call_time=0.05), Sandbox(poses=48))
    assert fast.cycle_fits(None) and fast.cycle_fits(CYCLE_POSES * 0.001)
    assert fast.rest_fits(16) == 16 and not fast.cut_cases and not fast.cut_run
    assert not fast.cycle_fits(100.0)  # a cycle that took 100 s does not fit twice
