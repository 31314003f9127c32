"""Kinematic collision checks: sample spacing, hits named, the held target, detours."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from kr210_sim.cell.layout import CellLayout
from kr210_sim.cell.load import load_model, model_for
from kr210_sim.cell.spec import MotionConfig, TargetSpec
from kr210_sim.cell.toml import PUBLISHED_CELL
from kr210_sim.errors import NoPathError
from kr210_sim.plan.collide import (
    HOLD_TILT_DEG,
    SAMPLE_ANGLE,
    SAMPLE_TRAVEL,
    CollisionChecker,
    check_samples,
)
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


# -- the four truths ------------------------------------------------------------------------
def _distance(model: mujoco.MjModel, q: np.ndarray, geom: str, other: str) -> float:
    """mj_geomDistance between two geoms of ``model`` (as built) with the arm at ``q``."""
    d = mujoco.MjData(model)
    h = CollisionChecker(model, committed()).handles
    d.qpos[h.arm_qpos] = q
    d.qpos[h.finger_qpos] = model.actuator_ctrlrange[h.grip_act, 0]
    mujoco.mj_kinematics(model, d)
    g1 = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, geom)
    g2 = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, other)
    return float(mujoco.mj_geomDistance(model, d, g1, g2, 1.0, np.zeros(6)))


def test_a_box_2_mm_from_a_box_obstacle_is_a_hit_and_10_mm_is_clear() -> None:
    """MuJoCo's box-box collider ignores margins: the finger pad (a box) 2 mm from the column
    (a box) must still count, as mj_geomDistance measures it."""
    model = model_for(cell=CELLS / "column.toml")
    checker = CollisionChecker(model, committed())
    base = np.array([0.0, -0.2, 0.2, 0.0, 0.0, 0.0])

    def at(gap: float) -> np.ndarray:  # joint 1 turned until the pad is ``gap`` from the column
        lo, hi = 0.2, 0.5
        for _ in range(50):
            mid = (lo + hi) / 2
            q = base + np.array([mid, 0, 0, 0, 0, 0])
            lo, hi = (
                (mid, hi)
                if _distance(model, q, "left_finger_pad", "obstacle_1") > gap
                else (lo, mid)
            )
        return base + np.array([lo, 0, 0, 0, 0, 0])

    q2, q10 = at(0.002), at(0.010)
    assert _distance(model, q2, "left_finger_pad", "obstacle_1") == pytest.approx(0.002, abs=1e-4)
    hit = checker.first_hit(q2[None])
    assert hit is not None and hit.kind == "cell" and hit.cell == "obstacle_1"
    assert checker.first_hit(q10[None]) is None


def test_the_held_cylinder_tilts_with_the_gripper() -> None:
    """A 0.6 m cylinder held by a gripper tilted 25 deg about its x axis swings its lower end
    0.13 m sideways: a box there is struck by the tilted cylinder, not by an upright one."""
    model = model_for(cell=CELLS / "column.toml")
    ready = np.array(MotionConfig().ready_q)
    T = np.eye(4)
    T[:3, 3] = (1.6, 0.0, 1.8)
    c, s = math.cos(math.radians(25)), math.sin(math.radians(25))
    T[:3, :3] = [[1, 0, 0], [0, c, -s], [0, s, c]]
    q_tilted = kinematics.nearest(T, ready)
    T[:3, :3] = np.eye(3)
    q_upright = kinematics.nearest(T, ready)
    long = TargetSpec(radius=0.05, length=0.6)
    offset = np.array([0.2, 0.0, 0.0])
    end = T[:3, :3] @ offset + T[:3, 3] + (0.0, 0.3 * s, -0.3 * c)  # the tilted lower end
    i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "obstacle_1")
    # a 0.1 m cube beside the tilted end, 0.01 m into the cylinder
    model.geom_pos[i] = end + np.array([0.0, 0.09, 0.0])
    model.geom_size[i] = (0.05, 0.05, 0.05)
    model.geom_rbound[i] = math.sqrt(3 * 0.05**2)
    model.geom_aabb[i, 3:] = 0.05
    checker = CollisionChecker(model, committed())
    assert checker.first_hit(q_upright[None], long, offset) is None
    hit = checker.first_hit(q_tilted[None], long, offset)
    assert hit is not None and hit.robot == "the held target" and hit.cell == "obstacle_1"


def test_the_gripper_folded_into_link_2_is_a_self_collision(checker: CollisionChecker) -> None:
    """Elbow fully bent, wrist folded back: the fingers reach into links 2 and 1 (no cell part
    is touched, so before self-collision was checked this state passed)."""
    q = np.array([0.0, -0.785, 1.134, 0.0, 1.963, 0.0])
    hit = checker.first_hit(q[None])
    assert hit is not None and hit.kind == "self" and "finger" in hit.robot
    assert hit.cell.startswith(("link_1", "link_2"))
    assert "against the arm's own link_" in hit.describe()


def test_the_held_part_stays_upright_and_the_drop_wrist_untwisted() -> None:
    """Shelf on the other side, slot 8 to drop 1: the nearest drop solution reaches over the
    arm's head (q6 = -pi) and points the fingers up halfway; it breaks the tilt bound, and the
    planner takes the untwisted one, whose carry keeps the part within 30 deg of upright."""
    model = model_for(cell=CELLS / "other_side.toml")
    layout = CellLayout.from_model(model)
    planner = Planner(load_robot(), MotionConfig(), None, CollisionChecker(model, committed()))
    t = layout.target
    grasp = planner.plan_grasp(
        planner.ready_q, layout.slots[7] + (0, 0, t.length / 2), t.radius, t.length
    )
    q0 = grasp.retreat.q_end
    T_drop = planner.drop_pose(layout.drop_spots[0], t.radius)
    twisted = planner.ptp("carry", q0, kinematics.nearest(T_drop, q0))
    assert abs(twisted.q_end[5]) == pytest.approx(math.pi, abs=0.01)
    hit = planner._hit(twisted, t)
    assert hit is not None and hit.kind == "tilt" and "from upright" in hit.describe()
    carry = planner.plan_carry(q0, layout.drop_spots[0], t.radius, t.length)
    assert abs(carry.q_end[3]) < 0.1 and abs(carry.q_end[5]) < 0.1
    up = kinematics.forward(check_samples(carry.trajectory, committed()))[:, 2, 2]
    assert up.min() > math.cos(math.radians(HOLD_TILT_DEG))
