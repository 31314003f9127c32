"""Sensor looks: MuJoCo's depth is along the optical axis (a tilted plane at a known distance),
K from fovy puts known points where they are rendered, and a look at the cell puts the target's
surface where the simulator holds it."""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

from kr210_sim.cell.layout import CellLayout, ready_pose
from kr210_sim.cell.load import model_at
from kr210_sim.errors import ConfigError
from kr210_sim.perception.camera import project
from kr210_sim.sensors.render import SensorRig
from kr210_sim.sensors.truth import shelf_truth
from kr210_sim.sim.cell import Cell
from kr210_sim.sim.targets import place_upright
from kr210_sim.util.paths import SCENES_DIR

pytestmark = pytest.mark.render

W, H, FOVY = 320, 240, 50.0


def _scene(distance: float, tilt_deg: float, markers: list[tuple[float, float, float]]) -> str:
    """A camera at the origin looking along +x (image right = -y, image down = -z), a plane
    ``distance`` ahead turned ``tilt_deg`` about z, and small spheres at ``markers``."""
    a = math.radians(tilt_deg)
    n = np.array([math.cos(a), math.sin(a), 0.0])
    centre = np.array([distance, 0.0, 0.0]) + 0.01 * n
    quat = (math.cos(a / 2), 0.0, 0.0, math.sin(a / 2))
    spheres = "\n".join(
        f'<geom name="m{i}" type="sphere" size="0.04" pos="{x} {y} {z}" rgba="1 0 0 1"/>'
        for i, (x, y, z) in enumerate(markers)
    )
    plane = (
        f'<geom name="plane" type="box" size="0.01 6 6" pos="{centre[0]} {centre[1]} {centre[2]}"'
        f' quat="{quat[0]} {quat[1]} {quat[2]} {quat[3]}"/>'
        if distance > 0
        else ""
    )
    return f"""<mujoco>
  <visual><global offwidth="{W}" offheight="{H}"/><map znear="0.001" zfar="100"/></visual>
  <statistic extent="4"/>
  <custom>
    <text name="sensors" data="cam"/>
    <numeric name="sensor_cam" data="0.05 50 0 {W} {H}"/>
    <text name="sensor_cam_noise" data="none"/>
    <text name="sensor_cam_mount" data="world"/>
  </custom>
  <worldbody>
    <light pos="0 0 3" dir="0 0 -1"/>
    <camera name="cam" pos="0 0 0" xyaxes="0 -1 0 0 0 1" fovy="{FOVY}"/>
    {plane}
    {spheres}
  </worldbody>
</mujoco>"""


def _look(xml: str) -> tuple[SensorRig, mujoco.MjData, np.ndarray, np.ndarray]:
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    rig = SensorRig(model)
    obs, seg = rig.look_with_truth(data, "cam")
    return rig, data, obs.depth, seg


@pytest.mark.parametrize(("distance", "tilt"), [(1.0, 0.0), (2.0, 30.0), (1.5, -40.0)])
def test_depth_is_the_distance_to_the_image_plane(distance: float, tilt: float) -> None:
    rig, _, depth, _ = _look(_scene(distance, tilt, []))
    K = rig.intrinsics("cam")
    # the plane n . p = distance cos(tilt) in the optical frame, n = (-sin, 0, cos)
    a = math.radians(tilt)
    u = (np.arange(W) - K.cx) / K.fx
    expected = distance * math.cos(a) / (math.cos(a) - math.sin(a) * u)
    expected = np.broadcast_to(expected, (H, W))
    assert np.all(depth > 0)
    err = np.abs(depth - expected)
    assert err.max() < 2e-4 * distance, err.max()
    # not the distance along the ray, which is up to 1/cos(half the diagonal) longer
    assert (
        np.abs(depth[0, 0] * math.sqrt(1 + u[0] ** 2 + ((0 - K.cy) / K.fy) ** 2) - depth[0, 0])
        > 0.05
    )
    rig.close()


def test_k_from_fovy_projects_known_points_onto_their_rendered_pixels() -> None:
    markers = [(2.0, 0.0, 0.0), (2.0, 0.5, 0.3), (1.5, -0.4, -0.25), (3.0, 0.9, 0.6)]
    rig, data, _, seg = _look(_scene(0.0, 0.0, markers))
    K = rig.intrinsics("cam")
    assert K.fy == pytest.approx(0.5 * H / math.tan(math.radians(FOVY) / 2))
    T = rig.pose(data, "cam")
    for i, p in enumerate(markers):
        g = mujoco.mj_name2id(rig.model, mujoco.mjtObj.mjOBJ_GEOM, f"m{i}")
        v, u = np.nonzero(seg == g)
        assert len(u) > 10
        p_cam = T[:3, :3].T @ (np.array(p) - T[:3, 3])
        ((pu, pv),) = project(p_cam, K)
        assert abs(u.mean() - pu) < 0.3 and abs(v.mean() - pv) < 0.3, (u.mean(), pu, v.mean(), pv)
    rig.close()


def test_the_fixed_sensor_sees_the_targets_surface_where_the_simulator_holds_it() -> None:
    model = model_at(SCENES_DIR / "cells" / "published.toml")
    layout = CellLayout.from_model(model)
    cell = Cell(model)
    cell.reset(ready_pose(model))
    data = cell.data
    slot = layout.slots[4]
    place_upright(cell, 0, (slot[0], slot[1], slot[2] + layout.target.length / 2.0))
    mujoco.mj_forward(model, data)
    rig = SensorRig(model)
    obs, seg = rig.look_with_truth(data, "shelf_rgbd", noise=False)
    truth = [o for o in shelf_truth(model, data, layout) if o.is_target]
    assert len(truth) == 1
    pts, colours = obs.cloud()
    mask = (seg == truth[0].geom)[obs.depth > 0]
    on = pts[mask]
    assert len(on) > 300
    axis_xy = truth[0].position[:2]
    r = np.linalg.norm(on[:, :2] - axis_xy, axis=1)
    side = np.abs(on[:, 2] - truth[0].position[2]) < layout.target.length / 2.0 - 0.005
    # the visible side: every point at the radius, to a fraction of a millimetre
    assert np.abs(r[side] - layout.target.radius).max() < 1.5e-3
    assert np.median(colours[mask][:, 2]) > 150  # blue
    with pytest.raises(ConfigError, match="no sensor 'nope' \\(sensors: shelf_rgbd, gripper\\)"):
        rig.look(data, "nope")
    rig.close()


def test_a_scene_without_sensors_is_refused() -> None:
    model = mujoco.MjModel.from_xml_string("<mujoco><worldbody/></mujoco>")
    with pytest.raises(ConfigError, match="the scene has no sensors"):
        SensorRig(model)


@pytest.mark.parametrize(
    "path", sorted((SCENES_DIR / "cells").glob("*.toml")), ids=lambda p: p.stem
)
def test_the_default_fixed_sensor_frames_every_slot_of_every_example_cell(path: Path) -> None:
    model = model_at(path)
    layout = CellLayout.from_model(model)
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    rig = SensorRig(model)
    K, T = rig.intrinsics("shelf_rgbd"), rig.pose(data, "shelf_rgbd")
    for lift in (0.02, layout.target.length):
        pts = layout.slots + np.array([0.0, 0.0, lift])
        uv = project((pts - T[:3, 3]) @ T[:3, :3], K)
        assert np.all((uv[:, 0] > 0) & (uv[:, 0] < K.width - 1)), uv
        assert np.all((uv[:, 1] > 0) & (uv[:, 1] < K.height - 1)), uv


def test_a_look_is_seeded_by_the_sensor_and_the_time_and_none_is_perfect() -> None:
    model = model_at(SCENES_DIR / "cells" / "published.toml")
    cell = Cell(model)
    cell.reset(ready_pose(model))
    mujoco.mj_forward(model, cell.data)
    rig = SensorRig(model)
    a, b = rig.look(cell.data, "shelf_rgbd"), rig.look(cell.data, "shelf_rgbd")
    assert np.array_equal(a.depth, b.depth) and np.array_equal(a.rgb, b.rgb)
    cell.data.time += 0.5
    c = rig.look(cell.data, "shelf_rgbd")
    assert not np.array_equal(a.depth, c.depth) and c.time == pytest.approx(a.time + 0.5)
    rgb, depth, _ = rig.render(cell.data, "shelf_rgbd")
    perfect = rig.look(cell.data, "shelf_rgbd", noise=False)
    assert np.array_equal(perfect.rgb, rgb) and np.array_equal(perfect.depth, depth)
    assert depth.min() > 0.16  # everything in range: nothing missing
    # noisy: within a few RMS of the truth where not missing or flying
    ok = c.depth > 0
    err = np.abs(c.depth[ok] - depth[ok])
    assert np.median(err) < 0.01 and ok.mean() > 0.9
    rig.close()
