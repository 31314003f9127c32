"""A move is no_path only when every search of the escalation fails: the schedule in order,
stopping at the first success, and the column cell whose slot 6 one search refused (issue 42)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from kr210_sim.cell.load import model_for
from kr210_sim.cell.spec import MotionConfig
from kr210_sim.errors import NoPathError, PlanningError
from kr210_sim.plan.cellcheck import _Check
from kr210_sim.plan.collide import CollisionChecker
from kr210_sim.plan.escalation import SCHEDULE, Attempt, budget, describe, escalate
from kr210_sim.plan.planner import Planner
from kr210_sim.plan.routing import Router
from kr210_sim.plan.sampling_planner import SOLVE_CHECKS, plan_seed
from kr210_sim.robot.description import load_robot
from kr210_sim.robot.kinematics import Kinematics
from kr210_sim.sim.runner import RunConfig, Runner

#: The published cell with one column at (1.6, 1.6), by the ready pose (issue 42's).
COLUMN = Path(__file__).parent / "column_by_the_ready_pose.toml"


class _Searches:
    """A search that fails its first ``fails`` attempts: the first with no path, the next with
    a path refused (its timed samples collide), each making ``attempt.checks // 10`` checks."""

    def __init__(self, fails: int) -> None:
        self.fails = fails
        self.tried: list[Attempt] = []
        self.checks = 0

    def __call__(self, attempt: Attempt) -> str:
        self.tried.append(attempt)
        self.checks += attempt.checks // 10
        if len(self.tried) > self.fails:
            return f"path of seed {attempt.seed}"
        if len(self.tried) % 2:
            raise NoPathError(f"seed {attempt.seed}: no path within {attempt.checks}")
        raise PlanningError("the planned path, timed rest to rest, is not accepted")


def test_the_schedule_starts_with_the_single_search_and_allows_ten_times_its_checks() -> None:
    assert SCHEDULE[0] == Attempt("RRTConnect", 0, SOLVE_CHECKS) and SOLVE_CHECKS == 30_000
    assert budget(SCHEDULE) == 10 * SOLVE_CHECKS == 300_000
    assert [a.seed for a in SCHEDULE] == [0, 1, 2, 3, 4]
    assert [a.checks for a in SCHEDULE] == [30_000, 30_000, 60_000, 60_000, 120_000]
    assert [a.planner for a in SCHEDULE] == ["RRTConnect"] * 4 + ["RRT"]
    assert describe(SCHEDULE) == "RRTConnect seeds 0-3, then RRT seed 4"
    with pytest.raises(ValueError, match="unknown OMPL planner 'PRM'"):
        Attempt("PRM", 0, 1000)


def test_the_attempts_run_in_order_and_stop_at_the_first_success() -> None:
    searches = _Searches(fails=2)
    found = escalate(searches, lambda: searches.checks)
    assert found.result == "path of seed 2" and found.attempt == 2
    assert searches.tried == list(SCHEDULE[:3])
    assert found.checks == 3_000 + 3_000 + 6_000
    easy = _Searches(fails=0)  # an easy move pays for one search only
    assert escalate(easy, lambda: easy.checks).attempt == 0 and easy.tried == [SCHEDULE[0]]


def test_when_every_attempt_fails_no_path_says_which_and_how_many_checks() -> None:
    searches = _Searches(fails=len(SCHEDULE))
    with pytest.raises(NoPathError) as caught:
        escalate(searches, lambda: searches.checks)
    assert searches.tried == list(SCHEDULE)
    assert str(caught.value) == (
        "OMPL found no collision-free path in 5 searches (RRTConnect seeds 0-3, then RRT seed 4; "
        "300000 validity checks allowed), 30000 validity checks in all; "
        "the last: seed 4: no path within 120000"
    )


def test_each_attempt_draws_its_own_seed_from_the_moves_ends() -> None:
    a = np.array([0.0, -0.5, 0.5, 0.0, 0.0, 0.0])
    b = np.array([-0.3, 0.0, 0.2, 0.0, -0.2, 0.0])
    seeds = [plan_seed(a, b, False, k) for k in range(len(SCHEDULE))]
    assert seeds[0] == plan_seed(a, b, False)  # the first attempt is the single search
    assert len(set(seeds)) == len(seeds) and all(s % 2 == 1 for s in seeds)
    settled = b + 3e-6  # ends micrometres apart: the same seeds, attempt by attempt
    assert seeds == [plan_seed(a, settled, False, k) for k in range(len(SCHEDULE))]


def _slot_6_approach(planner: Planner) -> tuple[np.ndarray, np.ndarray]:
    """The column cell's slot 6 approach: from the ready pose to the standoff."""
    check = _Check.of(planner.checker.model, None, None)  # type: ignore[union-attr]
    T_standoff = planner.grasp_poses(check.target_at(6), check.layout.target.radius)[0]
    return planner.ready_q, planner.solve(T_standoff, planner.ready_q, "standoff")


def test_the_column_cells_slot_6_approach_is_found_by_the_second_attempt() -> None:
    """One search (the first attempt alone, as before) refuses it; the escalation finds it."""
    robot = load_robot()
    checker = CollisionChecker(model_for(cell=COLUMN), Kinematics(robot))
    planner = Planner(robot, MotionConfig(), None, checker)
    assert planner.router is not None and planner.checker is not None
    start, goal = _slot_6_approach(planner)
    planner.checker.hold(None, None)
    one = Router(planner.checker, Kinematics(robot), planner.limits, schedule=SCHEDULE[:1])
    with pytest.raises(NoPathError, match=r"^approach move: .* against obstacle_1 .*in 1 search "):
        one.route(start, goal, "approach")
    routed = planner.router.route(start, goal, "approach")
    assert routed.planner == "ompl" and planner.router.escalated == 1
    assert planner.router.hit(routed.trajectory) is None


def test_check_serves_the_column_cells_slot_6_and_run_plans_it_alike() -> None:
    """Issue 42: `check` said slot 6 was not served ("RRTConnect found no collision-free path
    within 30000 validity checks") and `run --seed 2718` failed it with no_path."""
    model = model_for(cell=COLUMN)
    row = _Check.of(model, None, None).slot_row(6)
    assert row.served and "approach" in row.planner, row.detail
    runner = Runner(RunConfig(cycles=1), model=model)
    sample, k = runner.start_cycle(1, 6)
    plan = runner.plan_cycle(runner.observe_target(k), sample.spec)
    assert plan.drop_spot + 1 == row.drop_spot and plan.moves[0].planner == "ompl"


def test_a_move_no_attempt_solves_is_no_path_with_every_check_counted() -> None:
    """The same approach with two small attempts: both searches run out of checks (RRT too),
    and the verdict counts the checks of both."""
    robot = load_robot()
    checker = CollisionChecker(model_for(cell=COLUMN), Kinematics(robot))
    planner = Planner(robot, MotionConfig(), None, checker)
    start, goal = _slot_6_approach(planner)
    checker.hold(None, None)
    small = (Attempt("RRTConnect", 0, 400), Attempt("RRT", 1, 600))
    router = Router(checker, Kinematics(robot), planner.limits, schedule=small)
    c0 = checker.checks
    with pytest.raises(NoPathError) as caught:
        router.route(start, goal, "approach")
    made = checker.checks - c0
    message = str(caught.value)
    assert message.startswith("approach move: left_finger_lip against obstacle_1 at q [")
    assert (
        "; OMPL found no collision-free path in 2 searches (RRTConnect seed 0, then RRT seed 1; "
        "1000 validity checks allowed), " in message
    )
    counted = int(message.split("allowed), ")[1].split(" validity checks in all")[0])
    assert 1000 <= counted <= made < 1100  # each search stops within a few checks of its budget
    last = r"the last: OMPL's RRT \(seed 1\) found no collision-free path within 600 validity"
    assert re.search(last + r" checks \(\d+ states checked\)$", message), message
