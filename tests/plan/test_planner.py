"""The planner's choice of IK branch: a slot in plain reach is not called unreachable because
the branch nearest the ready pose flips on the straight line in."""

from __future__ import annotations

import numpy as np
import pytest

from kr210_sim.cell.layout import CellLayout
from kr210_sim.cell.load import compile_cell
from kr210_sim.cell.spec import MotionConfig
from kr210_sim.cell.toml import PUBLISHED_CELL, parse_cell
from kr210_sim.plan.collide import CollisionChecker
from kr210_sim.plan.cycle import pick_order
from kr210_sim.plan.planner import Planner
from kr210_sim.robot.description import load_robot
from kr210_sim.robot.kinematics import Kinematics
from kr210_sim.sim.runner import RunConfig, Runner

#: Ready poses that made slots in plain reach "unreachable" [deg]: facing away, and every
#: joint at its lower limit.
BEHIND = (180, 0, 0, 0, 0, 0)
LOWER_LIMITS = (-185, -45, -210, -350, -125, -350)


def _planner(ready_deg: tuple[float, ...]) -> tuple[Planner, CellLayout]:
    ready = ", ".join(str(v) for v in ready_deg)
    model = compile_cell(
        parse_cell(PUBLISHED_CELL.read_text() + f"\n[robot]\nready_q = [{ready}]\n")
    )
    robot = load_robot()
    checker = CollisionChecker(model, Kinematics(robot))
    return Planner(robot, MotionConfig(), None, checker), CellLayout.from_model(model)


@pytest.mark.parametrize(("ready", "slots"), [(BEHIND, (8, 9)), (LOWER_LIMITS, (1, 2, 4, 5))])
def test_slots_in_plain_reach_are_planned_from_another_branch(
    ready: tuple[float, ...], slots: tuple[int, ...]
) -> None:
    """From these ready poses the branch nearest them flipped the wrist on the straight line
    to slot 8's grasp ("a joint jumps 3.14 rad between samples"), and the slot was scored
    unreachable."""
    planner, layout = _planner(ready)
    t = layout.target
    for slot in slots:
        p = layout.slots[slot - 1] + np.array([0.0, 0.0, t.length / 2.0])
        plan = planner.plan_cycle(planner.ready_q, p, t, layout.drop_spots)
        assert plan.phases[0] == "approach" and plan.drop_spot == 0


@pytest.mark.slow
def test_a_run_facing_away_serves_the_slot_straight_ahead() -> None:
    """`run` on the published cell with ``ready_q = [180, 0, 0, 0, 0, 0]``: slot 8 was
    `unreachable` (slots 6, 5 and 3 succeeded)."""
    ready = ", ".join(str(v) for v in BEHIND)
    model = compile_cell(
        parse_cell(PUBLISHED_CELL.read_text() + f"\n[robot]\nready_q = [{ready}]\n")
    )
    r = Runner(RunConfig(cycles=1), model=model).run_cycle(1, 8)
    assert r.success and r.env_contact_ticks == 0, r.detail


def test_pick_order_steps_down_either_list_alike() -> None:
    assert list(pick_order(3, 2)) == [(0, 0), (0, 1), (1, 0), (1, 1), (2, 0), (2, 1)]
    assert list(pick_order(1, 1)) == [(0, 0)]
    for n_spots, n_branches in ((1, 8), (9, 1), (9, 8), (4, 6)):
        pairs = list(pick_order(n_spots, n_branches))
        assert sorted(pairs) == [(s, b) for s in range(n_spots) for b in range(n_branches)]
        assert [s + b for s, b in pairs] == sorted(s + b for s, b in pairs)


def test_a_wrist_turned_over_at_the_ready_pose_costs_one_failed_carry() -> None:
    """With the ready pose's wrist turned over, the nearest branch's retreat keeps it so, and
    the held target tilts past 30 deg on the carry to every drop spot: 9 OMPL searches (one a
    drop spot, 9.9 s) before the next branch was tried; now one, and the same cycle."""
    planner, layout = _planner((0, 0, 0, 180, 30, 180))
    t = layout.target
    p = layout.slots[4] + np.array([0.0, 0.0, t.length / 2.0])
    assert planner.router is not None
    planner.router.searches = 0
    plan = planner.plan_cycle(planner.ready_q, p, t, layout.drop_spots)
    assert planner.router.searches == 1
    assert plan.drop_spot == 0  # the drop spot in turn
    assert abs(plan.end_of("retreat")[3]) < 0.01  # from the branch with the wrist untwisted
