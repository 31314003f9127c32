"""The cell's look is visual only, the collision geometry is kept, and the cameras see right."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from kr210_sim.cell.handles import CellHandles
from kr210_sim.cell.load import load_model
from kr210_sim.cell.toml import PUBLISHED_CELL, load_cell
from kr210_sim.media.render import make_renderer, render_frame
from kr210_sim.robot.description import ARM_LINKS

#: Published link masses [kg] (the dressing must not add any).
MASSES = {
    "base_link": 150.0,
    "link_1": 138.0,
    "link_2": 95.0,
    "link_3": 71.0,
    "link_4": 17.0,
    "link_5": 7.0,
    "link_6": 0.5,
    "gripper_link": 0.3,
}


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return load_model()


def test_every_drawn_only_geom_is_massless_and_collides_with_nothing(
    model: mujoco.MjModel,
) -> None:
    visual = [g for g in range(model.ngeom) if model.geom_group[g] == 2]
    names = {model.geom(g).name for g in visual}
    assert {"rack_0", "cage_0", "cage_panel_0_p", "floor_plate", "link_1_visual_black"} <= names
    for g in visual:
        assert model.geom_contype[g] == 0 and model.geom_conaffinity[g] == 0, model.geom(g).name
    for name, mass in MASSES.items():
        assert model.body(name).mass[0] == pytest.approx(mass, rel=1e-9)
    assert set(MASSES) == set(ARM_LINKS)


def test_shelf_and_bin_keep_their_collision_boxes_hidden_under_the_dressing(
    model: mujoco.MjModel,
) -> None:
    h = CellHandles.from_model(model)
    colliding = {
        body: sorted(
            model.geom(g).name
            for g in (h.shelf_geoms if body == "shelf" else h.bin_geoms)
            if model.geom_contype[g]
        )
        for body in ("shelf", "bin")
    }
    assert len(colliding["shelf"]) == 9 and "shelf_board_2" in colliding["shelf"]
    assert colliding["bin"] == sorted(
        ["bin_floor", "bin_wall_px", "bin_wall_nx", "bin_wall_py", "bin_wall_ny"]
    )
    for g in h.shelf_geoms | h.bin_geoms:
        if model.geom_contype[g]:
            assert model.geom_group[g] == 3  # not drawn: the racking and the cage are
    # the cage's mesh walls are see-through
    panels = [g for g in h.bin_geoms if model.geom(g).name.startswith("cage_panel")]
    assert len(panels) == 4 and all(model.geom_rgba[g, 3] < 0.5 for g in panels)


def _in_view(model: mujoco.MjModel, data: mujoco.MjData, cam: int, p: np.ndarray) -> bool:
    """Whether point ``p`` [m] is inside camera ``cam``'s 4:3 image."""
    rel = data.cam_xmat[cam].reshape(3, 3).T @ (p - data.cam_xpos[cam])
    if rel[2] >= 0:  # behind the camera (it looks along -z)
        return False
    t = math.tan(math.radians(model.cam_fovy[cam]) / 2)
    return abs(rel[1] / -rel[2]) < t and abs(rel[0] / -rel[2]) < t * 4 / 3


def test_spare_cylinders_park_out_of_every_fixed_camera(model: mujoco.MjModel) -> None:
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    mujoco.mj_forward(model, data)
    cell = load_cell(PUBLISHED_CELL)
    names = [model.camera(i).name for i in range(model.ncam)]
    assert {"overview", "shelf", "bin", "gripper", "hero"} <= set(names)
    for cam, name in enumerate(names):
        if model.cam_bodyid[cam] != 0:
            continue  # the gripper camera moves with the arm
        for k in range(cell.n_targets):
            p = cell.park_position(k)
            for dz in (-0.125, 0.125):
                assert not _in_view(model, data, cam, p + np.array([0.0, 0.0, dz])), (name, k)
        if name == "overview":
            assert _in_view(model, data, cam, np.array([*cell.bin.position, 0.5]))


def test_a_cylinder_on_the_bin_floor_shows_in_the_overview(model: mujoco.MjModel) -> None:
    """The drops can be seen from the overview through the cage's mesh walls."""
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    h = CellHandles.from_model(model)
    cell = load_cell(PUBLISHED_CELL)
    a = int(h.target_qpos[0])
    bx, by = cell.bin.position
    data.qpos[a : a + 7] = (bx + 0.2, by - 0.2, cell.bin.floor_top + 0.05, 0.7071, 0.7071, 0, 0)
    mujoco.mj_forward(model, data)
    renderer = make_renderer(model, 320, 240)
    try:
        with_target = render_frame(renderer, data, "overview").astype(int)
        data.qpos[a : a + 3] = cell.park_position(0)
        mujoco.mj_forward(model, data)
        without = render_frame(renderer, data, "overview").astype(int)
    finally:
        renderer.close()
    changed = np.abs(with_target - without).sum(axis=2) > 60
    blue = with_target[..., 2] - with_target[..., 0] > 60
    assert (changed & blue).sum() > 20  # 35 px measured; behind opaque walls it would be 0


def _camera_ray(model: mujoco.MjModel, data: mujoco.MjData, cam: int, u: float, v: float):
    """Origin and unit direction of the ray through image point (u, v) in [-1, 1]^2 (u right,
    v up) of camera ``cam`` (4:3 image)."""
    fovy = math.radians(model.cam_fovy[cam])
    ty = math.tan(fovy / 2)
    local = np.array([u * ty * 4 / 3, v * ty, -1.0])
    d = data.cam_xmat[cam].reshape(3, 3) @ local
    return data.cam_xpos[cam].copy(), d / np.linalg.norm(d)


def test_the_drawn_floor_is_finite_but_every_fixed_camera_sees_ground_below_the_horizon(
    model: mujoco.MjModel,
) -> None:
    """The floor is drawn as a finite plane (an infinite one is drawn as a fine grid out to the
    far clip: a third of a software-rendered frame), large enough that no fixed camera sees its
    edge: every ray looking down hits something drawn."""
    floor = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "floor")
    assert model.geom_size[floor][0] > 0 and model.geom_size[floor][1] > 0
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    mujoco.mj_forward(model, data)
    drawn = np.array([1, 1, 1, 0, 0, 0], dtype=np.uint8)
    gid = np.zeros(1, dtype=np.int32)
    down = 0
    for cam in range(model.ncam):
        if model.cam_bodyid[cam] != 0:
            continue
        for u in np.linspace(-1, 1, 9):
            for v in np.linspace(-1, 1, 7):
                p, d = _camera_ray(model, data, cam, float(u), float(v))
                if d[2] >= -0.02:
                    continue
                down += 1
                dist = mujoco.mj_ray(model, data, p, d, drawn, 1, -1, gid)
                assert dist > 0, (model.camera(cam).name, u, v)
    assert down > 200


def test_the_floor_collides_as_an_infinite_plane_beyond_its_drawn_size(
    model: mujoco.MjModel,
) -> None:
    """A cylinder put down far beyond the drawn floor rests on it (MuJoCo's plane size is for
    drawing only)."""
    floor = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "floor")
    far = 3.0 * float(model.geom_size[floor][0])
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    a = int(CellHandles.from_model(model).target_qpos[0])
    data.qpos[a : a + 7] = (far, far, 0.3, 1, 0, 0, 0)
    for _ in range(1000):  # 2 s
        mujoco.mj_step(model, data)
    assert data.qpos[a + 2] == pytest.approx(0.125, abs=2e-3)
