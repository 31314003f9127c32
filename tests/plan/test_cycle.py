"""The cycle plan: the whole cycle's steps in order, their phases and the drop spot, planned
before the arm moves."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from kr210_sim.cell.layout import CellLayout
from kr210_sim.cell.load import load_model
from kr210_sim.cell.spec import MotionConfig
from kr210_sim.errors import UnreachablePoseError
from kr210_sim.plan.cycle import CyclePlan, Grip, drop_spot_index, drop_spot_order
from kr210_sim.plan.planner import Planner
from kr210_sim.robot import kinematics
from kr210_sim.robot.description import load_robot


@pytest.fixture(scope="module")
def cell() -> tuple[Planner, CellLayout]:
    return Planner(load_robot(), MotionConfig()), CellLayout.from_model(load_model())


def _target(layout: CellLayout, slot: int) -> np.ndarray:
    """The nominal target's centre in ``slot`` [m]."""
    return layout.slots[slot - 1] + np.array([0.0, 0.0, layout.target.length / 2.0])


def _plan(planner: Planner, layout: CellLayout, slot: int, placed: int = 0) -> CyclePlan:
    t = layout.target
    return planner.plan_cycle(planner.ready_q, _target(layout, slot), t, layout.drop_spots, placed)


def test_the_plan_is_the_whole_cycle_in_order(cell: tuple[Planner, CellLayout]) -> None:
    planner, layout = cell
    plan = _plan(planner, layout, 5)
    kinds = [(s.phase, s.move.kind if s.move else str(s.grip)) for s in plan.steps]
    assert kinds == [
        ("approach", "ptp"),
        ("approach", "lin"),
        ("grasp", "close"),
        ("lift", "lin"),
        ("retreat", "lin"),
        ("carry", "ptp"),
        ("release", "open"),
        ("return", "ptp"),
    ]
    assert plan.phases == ("approach", "grasp", "lift", "retreat", "carry", "release", "return")
    # the moves chain from the ready pose back to it, each ending at its named gripper pose
    moves = plan.moves
    assert np.allclose(moves[0].trajectory.q_start, planner.ready_q, atol=1e-12)
    assert np.allclose(moves[-1].q_end, planner.ready_q, atol=1e-9)
    for a, b in itertools.pairwise(moves):
        assert np.allclose(a.q_end, b.trajectory.q_start, atol=1e-9)
    posed = [s for s in plan.steps if s.T is not None]
    assert [s.pose for s in posed] == ["standoff", "grasp", "lift", "retreat", "drop"]
    for s in posed:
        assert s.move is not None
        assert np.allclose(kinematics.forward(s.move.q_end), s.T, atol=1e-6), s.pose
    assert np.array_equal(plan.end_of("standoff"), moves[0].q_end)
    with pytest.raises(KeyError, match="no move of the cycle ends at the 'bin' pose"):
        plan.end_of("bin")
    m = planner.motion
    grips = {s.grip: s.wait for s in plan.steps if s.grip is not None}
    assert grips == {Grip.CLOSE: m.close_timeout, Grip.OPEN: m.release_wait}
    assert plan.detours == 0 and plan.wall_time > 0 and plan.cpu_time > 0


def test_the_drop_spots_are_taken_in_turn(cell: tuple[Planner, CellLayout]) -> None:
    planner, layout = cell
    assert [drop_spot_index(i, 3) for i in range(7)] == [0, 1, 2, 0, 1, 2, 0]
    n = len(layout.drop_spots)
    for placed in (0, 4, n + 1):
        plan = _plan(planner, layout, 2, placed)
        assert plan.drop_spot == placed % n
        assert plan.drop_xy == tuple(layout.drop_spots[placed % n])
        carry = next(s for s in plan.steps if s.phase == "carry")
        expected = planner.drop_pose(layout.drop_spots[placed % n], layout.target.radius)
        assert carry.T is not None and np.array_equal(carry.T, expected)


def test_the_drop_spot_order_skips_what_is_not_usable_and_spreads_the_cylinders() -> None:
    """The spots a carry tries: the usable ones in turn from the one ``placed`` picks; with the
    cylinders carried to each so far, the least used first (in turn among equals)."""
    usable = (3, 4, 5, 6, 7, 8)  # a beam over the first row
    assert drop_spot_order(0, usable) == (3, 4, 5, 6, 7, 8)
    assert drop_spot_order(7, usable) == (4, 5, 6, 7, 8, 3)
    assert drop_spot_order(0, ()) == ()
    dropped = [0, 0, 0, 0, 0, 0, 2, 1, 1]  # only drops 7-9 reached, 7 twice
    assert drop_spot_order(3, (6, 7, 8), dropped) == (7, 8, 6)
    assert drop_spot_order(5, (6, 7, 8), dropped) == (8, 7, 6)
    # every spot used as often: the order in turn, as without counts
    assert drop_spot_order(5, tuple(range(9)), [1] * 9) == drop_spot_order(5, tuple(range(9)))


def test_a_spot_with_no_room_does_not_shift_the_turn_of_the_others() -> None:
    """A run's turn goes over its usable spots and skips those with no room for another
    cylinder (a cylinder standing there): with drop 1 taken, the second cylinder goes to drop
    2, as it did while drop 1 still had room; over the spots with room alone it went to 3."""
    usable, room = tuple(range(9)), tuple(range(1, 9))
    dropped = [1, 0, 0, 0, 0, 0, 0, 0, 0]
    assert drop_spot_order(1, room, dropped, usable) == (1, 2, 3, 4, 5, 6, 7, 8)
    assert drop_spot_order(1, room, dropped) == (2, 3, 4, 5, 6, 7, 8, 1)
    assert drop_spot_order(4, (6, 7), [0] * 9, usable) == (6, 7)
    assert drop_spot_order(7, (6, 7), [0] * 9, usable) == (7, 6)
    assert drop_spot_order(7, (6, 7), [0] * 9, (6, 7)) == drop_spot_order(7, (6, 7), [0] * 9)


def test_a_carry_goes_to_the_next_spot_whose_place_can_be_planned(
    cell: tuple[Planner, CellLayout],
) -> None:
    """Drop spot 2's place fails (its pose is moved out of reach): the carry goes to drop 3,
    the next in turn; with only drop 2 to use, the cycle says why it cannot be planned."""
    planner, layout = cell
    spots = layout.drop_spots.copy()
    spots[1] = (0.0, 4.0)  # beyond the arm's reach
    plan = planner.plan_cycle(planner.ready_q, _target(layout, 5), layout.target, spots, 1)
    assert plan.drop_spot == 2
    with pytest.raises(UnreachablePoseError, match="drop pose"):
        planner.plan_place(plan.end_of("retreat"), layout.target, spots, 0, (1,))


def test_a_cycle_ends_with_the_place_part(cell: tuple[Planner, CellLayout]) -> None:
    planner, layout = cell
    plan = _plan(planner, layout, 3, placed=2)
    place = planner.plan_place(plan.moves[-3].q_end, layout.target, layout.drop_spots, 2)
    assert place.phases == ("carry", "release", "return") == plan.phases[-3:]
    assert (
        (place.drop_spot, place.drop_xy)
        == (plan.drop_spot, plan.drop_xy)
        == (
            2,
            tuple(layout.drop_spots[2]),
        )
    )
    for a, b in zip(place.steps, plan.steps[-3:], strict=True):
        assert (a.phase, a.grip, a.wait, a.pose) == (b.phase, b.grip, b.wait, b.pose)
        if a.move is not None and b.move is not None:
            assert np.array_equal(a.move.q_end, b.move.q_end)
