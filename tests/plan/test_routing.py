"""Direct moves first, OMPL around what blocks them; a clear ready pose; straight lines that
stay straight; the duration of every move against its lower bound."""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

from kr210_sim.cell.layout import CellLayout
from kr210_sim.cell.load import compile_cell, model_for
from kr210_sim.cell.spec import MotionConfig, TargetSpec
from kr210_sim.cell.toml import PUBLISHED_CELL, parse_cell
from kr210_sim.errors import NoPathError
from kr210_sim.plan.collide import CollisionChecker
from kr210_sim.plan.planner import Planner
from kr210_sim.plan.routing import path_lengths
from kr210_sim.robot.description import load_robot
from kr210_sim.robot.kinematics import Kinematics
from kr210_sim.score.report import summarise
from kr210_sim.sim.runner import RunConfig, Runner

CELLS = PUBLISHED_CELL.parent


def _planner(model: mujoco.MjModel) -> Planner:
    robot = load_robot()
    return Planner(robot, MotionConfig(), None, CollisionChecker(model, Kinematics(robot)))


def _box(
    model: mujoco.MjModel,
    center: tuple[float, float, float],
    half: float | tuple[float, float, float],
) -> None:
    """Move and resize the cell's obstacle_1 (alone in its body) to a box of half extents
    ``half`` [m] (one number: a cube); the body's bounding volume is kept about its inertial
    frame, which moves with it."""
    i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "obstacle_1")
    size = np.broadcast_to(np.asarray(half, dtype=np.float64), (3,))
    model.geom_pos[i] = center
    model.body_ipos[model.geom_bodyid[i]] = center
    model.geom_size[i] = size
    model.geom_rbound[i] = float(np.linalg.norm(size))
    model.geom_aabb[i, 3:] = size


def test_a_blocked_ready_pose_gives_way_to_the_nearest_clear_one() -> None:
    model = model_for(cell=CELLS / "column.toml")
    configured = np.array(MotionConfig().ready_q)
    T = Kinematics(load_robot()).forward(configured)
    _box(model, tuple(T[:3, :3] @ (0.25, 0.0, 0.0) + T[:3, 3]), 0.15)  # round the fingers
    planner = _planner(model)
    assert planner.ready_note.startswith("the ready pose collides (")
    assert "against obstacle_1" in planner.ready_note
    assert planner.checker is not None and planner.checker.scan(planner.ready_q[None]) is None
    moved = planner.router.sampler.distance(configured, planner.ready_q)  # type: ignore[union-attr]
    assert 0.0 < moved < 0.5  # [m] of gripper travel at most
    slot = np.array([2.6, 0.0, 1.681])
    plan = planner.plan_grasp(planner.ready_q, slot, 0.05, 0.25)
    assert np.allclose(plan.approach_ptp.trajectory.q_start, planner.ready_q)


def test_the_cell_files_ready_pose_is_used(ready_cell: Path) -> None:
    planner = _planner(compile_cell(parse_cell(ready_cell.read_text())))
    assert np.allclose(np.degrees(planner.ready_q), [40, -15, 20, 0, -5, 0])
    assert planner.ready_note == ""


def test_a_blocked_straight_line_is_no_path_with_what_blocks() -> None:
    """A plate across the middle bay's opening, at the grasp height: every heading's approach
    line strikes it."""
    model = model_for(cell=CELLS / "column.toml")
    _box(model, (2.2, 0.0, 1.68), (0.025, 0.45, 0.025))
    planner = _planner(model)
    with pytest.raises(
        NoPathError,
        match=r"approach straight-line move: .* against obstacle_1 .*; no other heading within "
        r"45 deg of the radial is clear either",
    ):
        planner.plan_grasp(planner.ready_q, np.array([2.6, 0.0, 1.681]), 0.05, 0.25)


def test_a_pick_blocked_radially_is_made_from_another_heading() -> None:
    """A 5 cm cube on the middle slot's radial approach line, 0.4 m before the target: the
    gripper or a finger strikes it up to 20 deg off the radial, the pick points 25 deg off it
    (the positive side first), along straight lines that keep clear."""
    model = model_for(cell=CELLS / "column.toml")
    _box(model, (2.2, 0.0, 1.68), 0.025)
    planner = _planner(model)
    plan = planner.plan_grasp(planner.ready_q, np.array([2.6, 0.0, 1.681]), 0.05, 0.25)
    assert math.degrees(plan.yaw) == pytest.approx(25.0)
    assert plan.T_grasp[:3, 0] == pytest.approx([math.cos(plan.yaw), math.sin(plan.yaw), 0.0])
    assert [m.planner for m in (plan.approach_lin, plan.lift, plan.retreat)] == ["direct"] * 3
    for move in (plan.approach_ptp, plan.approach_lin, plan.lift):
        assert planner._hit(move, None) is None


def test_a_column_beside_the_shelf_is_picked_past_and_run_clear() -> None:
    """The column moved to (2.0, 0.55), by the slots of the shelf's left bay: link 4 strikes it
    at every radial pose of slot 1 (which failed every cycle), the pick 30 deg off the radial
    passes it; the cycle runs with no contact."""
    text = (CELLS / "column.toml").read_text()
    text = text.replace("position = [1.8, 1.0, 1.5]", "position = [2.0, 0.55, 1.5]")
    model = compile_cell(parse_cell(text))
    runner = Runner(RunConfig(cycles=1), model=model)
    r = runner.run_cycle(1, 1)
    assert r.success and r.env_contact_ticks == 0
    t = CellLayout.from_model(model).target
    slot = CellLayout.from_model(model).slots[0] + (0.0, 0.0, t.length / 2)
    plan = runner.planner.plan_grasp(runner.planner.ready_q, slot, t.radius, t.length)
    assert math.degrees(plan.yaw - math.atan2(slot[1], slot[0])) == pytest.approx(-30.0)


def test_ompl_moves_are_seeded_clear_and_not_far_above_their_bound() -> None:
    model = model_for(cell=CELLS / "column.toml")
    slot = np.array([2.6, 0.9, 0.914])
    a = _planner(model).plan_grasp(np.array(MotionConfig().ready_q), slot, 0.05, 0.25)
    b = _planner(model).plan_grasp(np.array(MotionConfig().ready_q), slot, 0.05, 0.25)
    move = a.approach_ptp
    assert move.planner == "ompl" and b.approach_ptp.planner == "ompl"
    ts = np.linspace(0, move.trajectory.duration, 50)
    assert np.array_equal(
        move.trajectory.sample_many(ts)[0], b.approach_ptp.trajectory.sample_many(ts)[0]
    )
    assert 1.0 <= move.trajectory.duration / move.bound < 1.5
    joint, gripper = path_lengths(move.trajectory, Kinematics(load_robot()))
    assert joint > 1.0 and gripper > 1.0
    assert a.approach_lin.planner == "direct" and a.approach_lin.bound > 0


def test_a_cycle_reports_each_moves_duration_and_bound() -> None:
    runner = Runner(RunConfig(cycles=1))
    r = runner.run_cycle(1, 5)
    assert r.success
    assert [m[0] for m in r.moves] == ["approach", "approach", "lift", "retreat", "carry", "return"]
    assert all(m[1] == "direct" and m[2] >= m[3] > 0 for m in r.moves)
    summary = summarise([r])
    ratio = summary["motion_time_over_bound"]
    assert ratio["mean"] == pytest.approx(r.bound_ratio) and 1.0 < ratio["mean"] < 1.3


def test_the_empty_gripper_moves_at_the_higher_jerk_the_grip_moves_do_not() -> None:
    """The approach to the standoff and the return run at ``jerk_scale`` (24), shorter than at
    12; the lines in and out of the shelf and the carry at ``grip_jerk_scale`` (12), unchanged."""
    robot = load_robot()
    slot = np.array([2.6, 0.0, 1.681])
    drops = np.array([[0.0, 2.5]])
    target = TargetSpec(radius=0.05, length=0.25)
    durations = []
    for motion in (MotionConfig(), MotionConfig(jerk_scale=12.0)):
        planner = Planner(robot, motion)
        plan = planner.plan_cycle(planner.ready_q, slot, target, drops)
        durations.append({f"{m.phase} {m.kind}": m.trajectory.duration for m in plan.moves})
    fast, slow = durations
    assert fast["approach ptp"] < slow["approach ptp"] - 0.03
    assert fast["return ptp"] < slow["return ptp"] - 0.03
    for key in ("approach lin", "lift lin", "retreat lin", "carry ptp"):
        assert fast[key] == slow[key]


def test_a_move_planned_again_is_remembered_not_searched_again() -> None:
    """The same start, goal and hold: the same timed path (or the same no_path verdict), with
    no validity check; another hold is planned anew."""
    model = model_for(cell=CELLS / "column.toml")
    planner = _planner(model)
    router, checker = planner.router, planner.checker
    assert router is not None and checker is not None
    ready = planner.ready_q
    goal = planner.solve(planner.grasp_poses(np.array([2.6, 0.0, 1.681]), 0.05)[0], ready, "s")
    checker.hold(None, None)
    first = router.route(ready, goal, "approach")
    again = router.route(ready, goal, "approach")
    assert first.planner == "ompl" and first.checks > 1000 and again.checks == 0
    ts = np.linspace(0.0, first.trajectory.duration, 40)
    assert np.array_equal(first.trajectory.sample_many(ts)[0], again.trajectory.sample_many(ts)[0])
    assert again.bound == first.bound and again.hit == first.hit
    checker.hold(TargetSpec(radius=0.05, length=0.25), planner.held_offset(0.05))
    held = router.route(ready, goal, "approach")
    assert held.checks > 0
    blocked = np.array([0.333, 0.267, 0.464, 0.0, -0.731, 0.0])  # link 5 inside the column
    _box(model, (2.0, 0.55, 1.5), (0.15, 0.15, 1.5))
    walled = _planner(model)
    assert walled.router is not None
    for _ in range(2):
        c0 = walled.checker.checks  # type: ignore[union-attr]
        with pytest.raises(NoPathError, match="the goal of the move collides"):
            walled.router.route(walled.ready_q, blocked, "approach")
    assert walled.checker.checks == c0  # type: ignore[union-attr]
