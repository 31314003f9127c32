"""The MuJoCo cell: compiles cleanly, holds still, agrees with our kinematics, is current."""

from __future__ import annotations

import copy
import math

import mujoco
import numpy as np
import pytest

from kr210_sim.cell.handles import CellHandles
from kr210_sim.cell.load import load_model
from kr210_sim.cell.mjcf import build_scene, build_spec
from kr210_sim.cell.spec import MotionConfig
from kr210_sim.cell.toml import published_cell
from kr210_sim.plan.planner import Planner
from kr210_sim.plan.poses import grasp_depth, radial_yaw
from kr210_sim.robot import kinematics as kin
from kr210_sim.robot.description import ARM_JOINTS, ARM_LINKS, FINGER_JOINTS, load_robot
from kr210_sim.sim.cell import Cell, hold
from kr210_sim.util.paths import SCENE_PATH


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return load_model()


def test_names_kept_from_urdf(model: mujoco.MjModel) -> None:
    for name in (*ARM_JOINTS, *FINGER_JOINTS):
        assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name) >= 0
    for name in ("base_link", "gripper_link", "link_6"):
        assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name) >= 0
    for name in ("tcp", "gripper"):
        assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, name) >= 0
    for name in ("overview", "shelf", "gripper"):
        assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, name) >= 0
    assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home") >= 0
    assert model.nu == 7
    assert len(CellHandles.from_model(model).target_bodies) == 10


def test_holds_home_for_two_seconds(model: mujoco.MjModel) -> None:
    cell = Cell(model)
    q0 = np.array(MotionConfig().ready_q)
    cell.reset(q0)
    cell.track(hold(q0, 2.0))
    assert np.degrees(np.abs(cell.q - q0)).max() < 0.1
    assert not cell.data.warning.number.any()


def test_random_control_raises_no_warning(model: mujoco.MjModel) -> None:
    """Menagerie's check: step the scene under random in-range control, no data.warning fires."""
    rng = np.random.default_rng(0)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    # Arm servos are not control-limited: draw their targets from their joints' ranges.
    bounds = np.where(
        model.actuator_ctrllimited[:, None].astype(bool),
        model.actuator_ctrlrange,
        model.jnt_range[model.actuator_trnid[:, 0]],
    )
    lo, hi = bounds.T
    assert (hi > lo).all()
    for _ in range(10):  # a new random command every 0.1 s, for 1 s
        data.ctrl[:] = rng.uniform(lo, hi)
        for _ in range(round(0.1 / model.opt.timestep)):
            mujoco.mj_step(model, data)
    assert not data.warning.number.any(), [w.number for w in data.warning]
    assert np.isfinite(data.qpos).all()


def test_mujoco_pose_matches_forward_kinematics(model: mujoco.MjModel) -> None:
    data = mujoco.MjData(model)
    h = CellHandles.from_model(model)
    rng = np.random.default_rng(6)
    robot = load_robot()
    qs = rng.uniform(robot.q_lower, robot.q_upper, size=(1000, 6))
    ours = kin.forward(qs)
    worst = 0.0
    for q, T in zip(qs, ours, strict=True):
        data.qpos[h.arm_qpos] = q
        mujoco.mj_kinematics(model, data)
        worst = max(
            worst,
            float(np.abs(data.xpos[h.gripper_body] - T[:3, 3]).max()),
            float(np.abs(data.xmat[h.gripper_body].reshape(3, 3) - T[:3, :3]).max()),
        )
    assert worst < 1e-9


@pytest.mark.parametrize("slot", range(1, 10))
def test_target_rests_in_each_slot(model: mujoco.MjModel, slot: int) -> None:
    cfg = published_cell()
    cell = Cell(model)
    q0 = np.array(MotionConfig().ready_q)
    cell.reset(q0)
    h = cell.handles
    a = int(h.target_qpos[0])
    p0 = cfg.slot(slot)
    cell.data.qpos[a : a + 3] = p0
    cell.data.qpos[a + 3 : a + 7] = (1, 0, 0, 0)
    mujoco.mj_forward(model, cell.data)
    cell.track(hold(q0, 2.0))
    p, _ = cell.target_pose(0)
    assert np.linalg.norm(p - p0) < 1e-3


def test_every_slot_and_drop_reachable(model: mujoco.MjModel) -> None:
    """Every grasp, pre-grasp and drop pose of the published cell has an IK solution, and that
    solution set in the built model puts MuJoCo's gripper_link on the pose (an FK independent
    of ours: the scene's joints as the builder wrote them)."""
    robot, motion, cell = load_robot(), MotionConfig(), published_cell()
    planner = Planner(robot, motion)
    sim = Cell(model)
    depth = grasp_depth(robot, cell.target.radius)
    reached = 0

    def reach(T: np.ndarray) -> None:
        nonlocal reached
        sim.reset(kin.nearest(T, np.zeros(6)))
        G = sim.gripper_pose()
        assert np.abs(G[:3, 3] - T[:3, 3]).max() < 1e-6, (G[:3, 3], T[:3, 3])
        assert np.abs(G[:3, :3] - T[:3, :3]).max() < 1e-6
        reached += 1

    for slot in range(1, 10):
        p = cell.slot(slot)
        yaw = radial_yaw(p)
        u = np.array([math.cos(yaw), math.sin(yaw), 0.0])
        for dist in (depth, depth + 0.4, depth + motion.standoff):  # grasp, published pre-grasp
            T = np.eye(4)
            T[:3, :3] = [[u[0], -u[1], 0], [u[1], u[0], 0], [0, 0, 1]]
            T[:3, 3] = p - dist * u
            reach(T)
    bx, by = cell.bin.position
    drops = cell.bin.drop_offsets()
    for dx, dy in drops:
        reach(planner.drop_pose((bx + dx, by + dy), cell.target.radius))
    assert len(drops) == 9 and reached == 9 * 3 + 9


def test_build_is_deterministic_and_committed_scene_is_current(tmp_path) -> None:  # type: ignore[no-untyped-def]
    a, b = tmp_path / "a", tmp_path / "b"
    (pa,) = build_scene(a)
    (pb,) = build_scene(b)
    assert pa.read_text() == pb.read_text()
    # mesh paths are relative to the output folder, so compare with meshdir normalised
    fresh = pa.read_text().replace(_meshdir(pa.read_text()), "MESHDIR")
    committed = SCENE_PATH.read_text().replace(_meshdir(SCENE_PATH.read_text()), "MESHDIR")
    assert fresh == committed, "scenes/ is stale: run `python -m kr210_sim build-scene`"


def _meshdir(xml: str) -> str:
    start = xml.index('meshdir="') + len('meshdir="')
    return xml[start : xml.index('"', start)]


def test_every_visual_vertex_lies_inside_its_links_colliders(model: mujoco.MjModel) -> None:
    """Computed from whatever meshes are in assets/: each link's hull collider is its mesh."""
    from colliders import stick_out

    worst = stick_out(model)
    assert set(worst) >= set(ARM_LINKS[1:])  # every moving link
    assert max(worst.values()) <= 0.005, worst
    # the URDF's primitives alone left the forearm tube of link 3 outside (the finding)
    assert stick_out(model, with_hulls=False)["link_3"] > 0.4


def test_hull_colliders_touch_the_cell_but_not_the_targets(model: mujoco.MjModel) -> None:
    hull = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "link_3_hull")
    board = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "shelf_board_1")
    target = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "target_0")

    def pairs(a: int, b: int) -> bool:
        ct, ca = model.geom_contype, model.geom_conaffinity
        return bool((ct[a] & ca[b]) or (ct[b] & ca[a]))

    assert pairs(hull, board) and not pairs(hull, target)
    assert pairs(target, board)


def test_the_lips_cannot_wedge_a_cylinder_between_them(model: mujoco.MjModel) -> None:
    """A lip touches the cylinder at its inner corner, where the surface normal leans
    acos(1 - depth / r) off the squeeze axis. A lip whose friction angle is larger wedges a
    cylinder pulled outward: the fingers spread until the lips alone carry the squeeze and the
    pads lose it (the 8 mm lips, 33 deg, at the target's friction 1.0, 45 deg, did on MuJoCo
    4.0.1: creep 3.5-5.8 mm a carry). The lips' own coefficient applies (their priority is above
    the targets') and lets every cylinder of the randomised range slide back onto the pads."""
    robot = load_robot()
    cell = published_cell()
    target = model.geom("target_0")
    radii = (cell.target.radius, *cell.randomization.radius)
    for side in ("left", "right"):
        lip = model.geom(f"{side}_finger_lip")
        assert 2.0 * lip.size[1] == pytest.approx(robot.lip_depth)
        assert lip.priority[0] > target.priority[0]  # the lip's friction is the contact's
        friction_angle = math.degrees(math.atan(lip.friction[0]))
        leans = [math.degrees(math.acos(1.0 - robot.lip_depth / r)) for r in radii]
        assert friction_angle < min(leans), (friction_angle, leans)
    assert robot.lip_depth == pytest.approx(0.018)
    assert [round(x, 1) for x in leans] == [50.2, 56.6, 45.6]
    # the 8 mm lips at the target's own friction wedged the nominal cylinder
    assert math.degrees(math.acos(1.0 - 0.008 / 0.05)) < math.degrees(math.atan(1.0))


def test_a_planning_build_keeps_the_finer_hulls(model: mujoco.MjModel) -> None:
    """build_spec(planning=True): the drawn meshes' own hulls, for kinematic checks; the stepped
    model's light hulls have under half their vertices and also enclose the drawn meshes."""
    from colliders import stick_out

    fine = build_spec(planning=True).compile()

    def hull_vertices(m: mujoco.MjModel) -> int:
        hulls = [g for g in range(m.ngeom) if m.geom(g).name.split("_hull")[0] != m.geom(g).name]
        return sum(int(m.mesh_graph[m.mesh_graphadr[m.geom_dataid[g]]]) for g in hulls)

    assert hull_vertices(model) < 0.5 * hull_vertices(fine)
    assert max(stick_out(fine).values()) <= 0.005


@pytest.mark.parametrize("v0", [0.2, 0.3])
def test_a_cylinder_rolling_on_its_side_stops_where_the_wood_floor_says(
    model: mujoco.MjModel, v0: float
) -> None:
    """A cylinder laid on its side on the bin floor and set rolling at ``v0`` [m/s] stops after
    1.5 v0^2 r / (2 b g): the rolling resistance torque b N (b = WOOD_ROLLING, iron on wood)
    brakes a solid cylinder (I = m r^2 / 2) rolling without slip. Without rolling resistance
    it would roll on to the far wall, 0.73 m away."""
    from kr210_sim.cell.layout import CellLayout
    from kr210_sim.cell.mjcf import WOOD_ROLLING

    m = copy.copy(model)
    cell, b = Cell(m), CellLayout.from_model(m).bin
    h = cell.handles
    r = float(m.geom_size[h.target_geoms[0], 0])
    a, dof = int(h.target_qpos[0]), int(h.target_dof[0])
    x0 = b.center[0] - b.inner_half[0] + 0.1
    q = np.array([math.cos(math.pi / 4), math.sin(math.pi / 4), 0.0, 0.0])  # axis along y
    cell.data.qpos[a : a + 7] = (x0, b.center[1], b.floor_top + r, *q)
    R = np.empty(9)
    mujoco.mju_quat2Mat(R, q)
    cell.data.qvel[dof : dof + 3] = (v0, 0.0, 0.0)
    cell.data.qvel[dof + 3 : dof + 6] = R.reshape(3, 3).T @ (0.0, v0 / r, 0.0)  # no slip
    mujoco.mj_forward(m, cell.data)
    steps = 0
    while cell.target_speed(0) > 1e-3 and steps < 2000:
        mujoco.mj_step(m, cell.data)
        steps += 1
    derived = 1.5 * v0**2 * r / (2 * WOOD_ROLLING * 9.81)
    rolled = float(cell.data.qpos[a] - x0)
    assert rolled == pytest.approx(derived, rel=0.1), (rolled, derived)
    assert steps * m.opt.timestep == pytest.approx(v0 / (WOOD_ROLLING * 9.81 / (1.5 * r)), rel=0.1)
