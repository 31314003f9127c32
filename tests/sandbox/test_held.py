"""The time a user's process was held off the CPU by others (sandbox/held.py): from the kernel's
figures of real processes, a wait on the run queue behind another process is held; a sleep, the
user's own processes taking its CPU and its quota's throttling are not; and a call's time limit
counts the user's own time, within twice the limit."""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np
import pytest
from cpu_hog import BUSY, CROWDED, SLEEPY, Others, hog, pinned

from kr210_sim.robot import kinematics
from kr210_sim.sandbox.held import HELD_SHARE, Sched, cpu_between, held, waited_between
from kr210_sim.sandbox.ik_sandbox import IkSandbox, IkTimeout, Limits
from kr210_sim.sandbox.jail import Jail

Q = np.array([0.3, 0.2, -0.3, 0.5, 0.6, -0.4])
T = kinematics.forward(Q)
S = 1_000_000_000  # ns a second
TICKS = os.sysconf("SC_CLK_TCK")  # clock ticks a second


def test_held_is_the_longest_wait_within_the_cpu_left_unused() -> None:
    before = Sched({1: (0, 0), 2: (0, 0)}, {1: 0})
    # one task waited 0.6 s, another 0.5 s, in 1 s of which the tree used 0.3 s of CPU
    after = Sched({1: (2 * S // 10, 6 * S // 10), 2: (S // 10, 5 * S // 10)}, {1: 3 * TICKS // 10})
    assert waited_between(before, after) == pytest.approx(0.6)
    assert cpu_between(before, after) == pytest.approx(0.3)
    assert held(before, after, 1.0) == pytest.approx(0.6)  # not 1.1: the waits overlap
    # its own CPU bounds it: 0.9 s used in 1 s leaves at most 0.1 s held
    busy = Sched(
        {1: (5 * S // 10, 6 * S // 10), 2: (4 * S // 10, 5 * S // 10)}, {1: 9 * TICKS // 10}
    )
    assert held(before, busy, 1.0) == pytest.approx(0.1)
    # the quota's throttling (0.3 s) is its own: 1 - 0.3 - 0.3
    throttled = Sched(after.tasks, after.ticks, None, 0.3)
    assert held(before, throttled, 1.0) == pytest.approx(0.4)


def test_ended_tasks_and_new_ones_count_from_their_start() -> None:
    before = Sched({1: (5 * S, 2 * S), 7: (S, S)}, {1: 6 * TICKS})
    # task 7 ended; task 9 is new; process 1's ticks count what its ended threads used
    after = Sched({1: (5 * S, 2 * S), 9: (S // 10, S // 5)}, {1: 6 * TICKS + 4 * TICKS // 10})
    assert waited_between(before, after) == pytest.approx(0.2)
    assert cpu_between(before, after) == pytest.approx(0.4)  # the ticks: 0.4 s
    assert held(before, after, 1.0) == pytest.approx(0.2)
    reused = Sched({1: (S // 10, S // 20)}, {})  # id 1 taken by a task younger than the first
    assert waited_between(before, reused) == pytest.approx(0.05)
    # the group's CPU time counts the tasks that ended before the second reading
    group = held(Sched(usage=0), Sched({1: (0, S)}, {}, usage=8 * S // 10), 1.0)
    assert group == pytest.approx(0.2)


def _box(tmp_path: Path, code: str, limit: float, jail: Jail | None = None) -> IkSandbox:
    (tmp_path / "user.py").write_text(code)
    box = IkSandbox(f"{tmp_path / 'user.py'}:solve", Limits(call_timeout=limit), confinement=jail)
    pinned(box.start)  # its processes on one CPU, the hog's
    return box


@pytest.mark.parametrize("jailed", [False, True], ids=["unconfined", "jailed"])
def test_a_call_held_behind_a_hog_may_take_its_limit_of_its_own_time(
    tmp_path: Path, jailed: bool, request: pytest.FixtureRequest
) -> None:
    """A call had its limit in wall time: a process that needs 0.5 s of CPU and waited as long
    again behind another process on its CPU timed out at 0.8 s. It now gets 0.8 s of its own
    time, and a call that sleeps past it still times out there."""
    if jailed:
        request.getfixturevalue("jail_ok")
    box = _box(tmp_path, BUSY, 0.8, Jail() if jailed else None)
    try:
        with hog():
            time.sleep(0.2)
            t = time.monotonic()
            np.testing.assert_allclose(box(T, Q), Q)
            wall = time.monotonic() - t
        assert wall - box.held == pytest.approx(0.5, abs=0.25)  # its CPU time, about
        assert 0.25 * wall <= box.held <= HELD_SHARE * 0.8
    finally:
        box.close()
    box = _box(tmp_path, SLEEPY, 0.3, Jail() if jailed else None)
    try:
        with hog():
            t = time.monotonic()
            with pytest.raises(IkTimeout, match=r"^no answer within 0\.3 s$"):
                box(T, Q)
            assert time.monotonic() - t < 0.45
        assert box.held < 0.05
    finally:
        box.close()


def _root(box: IkSandbox) -> int:
    """The first process of a sandbox's tree."""
    assert box._proc is not None
    return box._proc.pid


def test_its_own_processes_taking_its_cpu_are_not_held(tmp_path: Path) -> None:
    """Three processes of its own spinning beside the one that answers: that one waits on the
    run queue for most of the call, but for its own processes, so nothing is held beyond what
    other processes (tests beside this one, the machine's) took of its CPU."""
    box = _box(tmp_path, CROWDED, 30.0)
    try:
        box(T, Q)  # its processes started
        with Others(_root(box)) as others:
            box(T, Q)
        assert others.wall > 0.6  # it waited: 0.3 s of CPU in a CPU shared four ways
        # counted as held, its own processes' time would be about 3/4 of the wall time
        assert box.held < others.took + 0.1 * others.wall
    finally:
        box.close()


def test_its_quota_holding_it_back_is_not_held(tmp_path: Path, jail_ok: None) -> None:
    """A jail held to half a core waits on the run queue half the time, by its quota: its own
    doing, not held."""
    jail = Jail(cores=0.5)
    if not jail.limiter.cpu:
        pytest.skip("no cpu control group can be made here")
    box = _box(tmp_path, BUSY, 30.0, jail)
    try:
        with Others(_root(box)) as others:
            box(T, Q)
        assert others.wall > 0.8  # 0.5 s of CPU at half a core
        # counted as held, the quota's throttling would be about half the wall time
        assert box.held < others.took + 0.25 * others.wall
    finally:
        box.close()
