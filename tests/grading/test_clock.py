"""A graded student's own time (grading/clock.py), in its real jail beside a real CPU hog on its
CPU: the time it waited for the CPU behind the hog is not charged (a noisy classmate must not
cost an honest one its cases); its sleep, and what its own processes take from each other, are;
and a student held off the CPU for ever is still cut, within twice its budget."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
from cpu_hog import BUSY, CROWDED, SLEEPY, hog, pinned

from kr210_sim.grading.clock import StudentClock
from kr210_sim.grading.student import StudentJob, student_sandbox
from kr210_sim.robot import kinematics
from kr210_sim.sandbox.held import HELD_SHARE
from kr210_sim.sandbox.ik_sandbox import SandboxStop

Q = np.array([0.3, 0.2, -0.3, 0.5, 0.6, -0.4])
T = kinematics.forward(Q)


@pytest.fixture(autouse=True)
def _jail(jail_ok: None) -> None:
    """Every test here grades in the jail."""


def _clock(tmp_path: Path, code: str, budget: float = 60.0) -> StudentClock:
    """A student whose ``solve`` is ``code``, started (its processes on the hog's CPU)."""
    (tmp_path / "user.py").write_text(code)
    job = StudentJob(
        name="amy",
        spec=f"{tmp_path / 'user.py'}:solve",
        problem="",
        cases=0,
        cycles=1,
        seed=3,
        timeout=budget,
        ik_timeout=60.0,
        memory_mb=1024,
        min_success=0.8,
        scratch=str(tmp_path / "scratch"),
    )
    clock = StudentClock(student_sandbox(job), budget)
    pinned(clock.start)
    return clock


def _call(clock: StudentClock) -> tuple[float, float]:
    """One call: its wall time and the student's time charged for it [s]."""
    used, t = clock.used, time.monotonic()
    np.testing.assert_allclose(clock(T, Q), Q)
    return time.monotonic() - t, clock.used - used


def test_the_wait_behind_a_hog_is_not_charged_and_a_sleep_is(tmp_path: Path) -> None:
    """The student was charged the wall time of its calls, so a hog on its CPU (a noisy
    classmate) doubled what 0.5 s of CPU cost it."""
    clock = _clock(tmp_path, BUSY)
    try:
        with hog():
            time.sleep(0.2)
            for _ in range(2):
                wall, charged = _call(clock)
                assert wall > 0.7  # it did wait: 0.5 s of CPU on a CPU shared with the hog
                assert charged < 0.75 * wall
                assert charged == pytest.approx(0.5, abs=0.25)  # its CPU time, about
        assert clock.held == pytest.approx(clock.wall - clock.used, abs=1e-6)
    finally:
        clock.sandbox.close()
    clock = _clock(tmp_path, SLEEPY)
    try:
        with hog():
            wall, charged = _call(clock)
        assert charged >= 0.9 * wall >= 0.45  # asleep, it waits for nobody: charged whole
    finally:
        clock.sandbox.close()


def test_what_its_own_processes_take_from_it_is_charged(tmp_path: Path) -> None:
    """Three processes of its own spinning take most of its CPU from the one that answers; beside
    a hog it is charged as much as without one, not the CPU time of its answer alone."""
    clock = _clock(tmp_path, CROWDED)
    try:
        _call(clock)  # its processes started
        _, alone = _call(clock)
        assert alone > 0.6  # 0.3 s of CPU in a CPU shared four ways
        with hog():
            time.sleep(0.2)
            wall, charged = _call(clock)
        assert wall > 1.2 * alone  # the hog took its share
        assert charged >= 0.7 * alone
    finally:
        clock.sandbox.close()


def test_a_student_held_off_the_cpu_for_ever_is_cut_within_twice_its_budget(
    tmp_path: Path,
) -> None:
    """The time held is not charged, but a student that is always ready and never run cannot
    hold the grader for ever: its wait is moved on by the time held, at most by its budget."""
    clock = _clock(tmp_path, BUSY)
    try:
        clock.budget = clock.used + 1.0
        with hog(nice=-20) as greedy:  # about 1 % of its CPU left to the student
            time.sleep(0.2)
            if greedy.poll() is not None:
                pytest.skip("a hog at nice -20 needs root")
            t = time.monotonic()
            with pytest.raises(SandboxStop) as info:
                clock(T, Q)
            wall = time.monotonic() - t
        assert info.value.verdict == "timeout" and clock.spent
        # the time held was not charged, up to its budget; then it was cut (and killed, which
        # takes a while on a CPU the hog holds)
        assert 0.5 * HELD_SHARE * clock.budget <= clock.held <= HELD_SHARE * clock.budget + 1e-6
        assert wall < (1 + HELD_SHARE) * clock.budget + 1.5
        assert "s its processes were held off the CPU by others" in clock.spent_detail()
    finally:
        clock.sandbox.close()


def test_its_cpu_time_limit_leaves_room_for_the_time_held(tmp_path: Path) -> None:
    """RLIMIT_CPU was --timeout: a student charged its CPU time (its waits behind others not
    counted) reached it as its budget ran out, and was killed, ``crashed`` (measured: the sympy
    neighbour beside a noisy class, 119 s of CPU in its 120 s)."""
    (tmp_path / "user.py").write_text(BUSY)
    job = StudentJob(
        name="amy",
        spec=f"{tmp_path / 'user.py'}:solve",
        problem="",
        cases=0,
        cycles=1,
        seed=3,
        timeout=120.0,
        ik_timeout=2.0,
        memory_mb=1024,
        min_success=0.8,
        scratch=str(tmp_path / "scratch"),
    )
    box = student_sandbox(job)
    assert box.limits.cpu_s == (1 + HELD_SHARE) * 120.0
    box.close()
