"""Kinematic collision checks: sample spacing, hits named, the held target, detours."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from kr210_sim.cell.load import load_model, model_for
from kr210_sim.cell.spec import MotionConfig, TargetSpec
from kr210_sim.cell.toml import PUBLISHED_CELL
from kr210_sim.errors import NoPathError
from kr210_sim.plan.collide import SAMPLE_ANGLE, SAMPLE_TRAVEL, CollisionChecker, check_samples
from kr210_sim.plan.planner import Planner
from kr210_sim.plan.trajectory import JointLimits, plan_ptp
from kr210_sim.robot import kinematics
from kr210_sim.robot.description import load_robot
from kr210_sim.robot.kinematics import committed

CELLS = PUBLISHED_CELL.parent


@pytest.fixture(scope="module")
def checker() -> CollisionChecker:
    return CollisionChecker(load_model(), committed())


def test_samples_are_at_most_1_cm_and_1_deg_apart() -> None:
    limits = JointLimits.from_robot(load_robot(), MotionConfig())
    rng = np.random.default_rng(4)
    for _ in range(5):
        q0, q1 = rng.uniform(-1.0, 1.0, (2, 6))
        traj = plan_ptp(q0, q1, limits)
        qs = check_samples(traj, committed())
        assert np.allclose(qs[0], q0) and np.allclose(qs[-1], q1, atol=1e-9)
        assert np.abs(np.diff(qs, axis=0)).max() <= SAMPLE_ANGLE * 1.01
        p = kinematics.forward(qs)[:, :3, 3]
        assert np.linalg.norm(np.diff(p, axis=0), axis=1).max() <= SAMPLE_TRAVEL * 1.01


def test_the_arm_in_the_shelf_is_a_hit_and_the_ready_pose_is_clear(
    checker: CollisionChecker,
) -> None:
    ready = np.array(MotionConfig().ready_q)
    assert checker.first_hit(ready[None]) is None
    # joint 2 forward by 1.2 rad: the forearm drops through the shelf's boards
    q = np.array([0.0, 1.2, 0.0, 0.0, 0.0, 0.0])
    hit = checker.first_hit(np.array([ready, q]))
    assert hit is not None and hit.sample == 1
    assert hit.cell.startswith(("shelf_", "floor")) and (
        "hull" in hit.robot or "collision" in hit.robot
    )


def test_the_held_target_is_checked_against_the_cell(checker: CollisionChecker) -> None:
    """Gripper level 0.25 m above the bin's rim, 0.25 m before its wall: the arm clears the
    rim, the 0.8 m long cylinder it holds 0.3 m ahead does not."""
    T = np.eye(4)
    T[:3, 3] = (0.0, 1.75, 1.25)
    T[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]  # pointing along +y, towards the bin
    q = kinematics.nearest(T, np.array(MotionConfig().ready_q))
    assert checker.first_hit(q[None]) is None
    long = TargetSpec(radius=0.05, length=0.8)
    hit = checker.first_hit(q[None], long, (0.3, 0.0, 0.0))
    assert hit is not None and hit.robot == "the held target" and hit.cell.startswith("bin_")


def test_a_column_in_the_swing_is_detoured_around() -> None:
    model = model_for(cell=CELLS / "column.toml")
    planner = Planner(load_robot(), MotionConfig(), None, CollisionChecker(model, committed()))
    ready = planner.ready_q
    slot = np.array([2.6, 0.0, 1.681])
    direct = planner.ptp(
        "approach", ready, planner.solve(planner.grasp_poses(slot, 0.05)[0], ready, "s")
    )
    assert planner._hit(direct, None) is not None  # the direct swing strikes the column
    plan = planner.plan_grasp(ready, slot, 0.05, 0.25)
    assert planner.detours >= 1
    assert planner._hit(plan.approach_ptp, None) is None
    assert plan.approach_ptp.trajectory.duration > direct.trajectory.duration


def test_no_path_names_what_blocks() -> None:
    model = model_for(cell=CELLS / "column.toml")
    i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "obstacle_1")
    model.geom_size[i] = (3.0, 3.0, 1.5)  # a wall around everything: no detour clears it
    model.geom_rbound[i] = math.sqrt(3**2 + 3**2 + 1.5**2)
    model.geom_aabb[i, 3:] = (3.0, 3.0, 1.5)
    planner = Planner(load_robot(), MotionConfig(), None, CollisionChecker(model, committed()))
    with pytest.raises(NoPathError, match=r"move: .* against obstacle_1 at q \["):
        planner.plan_grasp(planner.ready_q, np.array([2.6, 0.0, 1.681]), 0.05, 0.25)
