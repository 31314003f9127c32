"""Cell files, the sections about seeing: sensors, object kinds, clutter and the pick list; what
the model holds of them, and every kind of bad entry."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from kr210_sim.cell.load import compile_cell
from kr210_sim.cell.robot_model import look_at
from kr210_sim.cell.sensing_layout import clutter_of, kinds_of, pick_list_of, sensors_of
from kr210_sim.cell.toml import PUBLISHED_CELL, load_cell, parse_cell
from kr210_sim.cli import main
from kr210_sim.errors import ConfigError
from kr210_sim.util.paths import SCENES_DIR

CLUTTERED = SCENES_DIR / "cells" / "cluttered.toml"
PUBLISHED = PUBLISHED_CELL.read_text()
SENSOR = """
[[sensors]]
name = "cam"
position = [0.5, -0.5, 2.0]
look_at = [2.5, 0.0, 1.5]
"""
KIND = """
[[objects]]
name = "red_can"
shape = "cylinder"
size = [0.045, 0.22]
color = [0.9, 0.1, 0.1]
"""


def test_a_cell_without_sensors_gets_a_fixed_rgbd_and_the_wrist_camera() -> None:
    cell = load_cell(PUBLISHED_CELL)
    assert [s.name for s in cell.sensors] == ["shelf_rgbd", "gripper"]
    fixed, wrist = cell.sensors
    assert (fixed.mount, fixed.noise, fixed.resolution) == ("world", "d415", (640, 480))
    assert (wrist.mount, wrist.noise, wrist.fovy_deg) == ("gripper", "d435", 70.0)
    assert cell.objects == () and cell.clutter is None and cell.pick == ("target",)
    model = compile_cell(cell)
    # the wrist sensor is the robot's own camera, as it was: one camera named gripper
    names = [model.camera(i).name for i in range(model.ncam)]
    assert names.count("gripper") == 1 and "shelf_rgbd" in names
    cam = model.camera("gripper")
    assert cam.fovy[0] == 70.0 and tuple(model.cam_resolution[cam.id]) == (640, 480)
    assert np.allclose(cam.pos, (-0.08, 0.0, 0.16))
    # the xyaxes the robot model gave it before sensors existed
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    x, y = np.array(look_at([-0.08, 0, 0.16], [0.35, 0, 0])).reshape(2, 3)
    R_body = data.xmat[model.body("gripper_link").id].reshape(3, 3)
    R_cam = data.cam_xmat[cam.id].reshape(3, 3)
    assert np.allclose(R_body.T @ R_cam[:, 0], x, atol=1e-6)
    assert np.allclose(R_body.T @ R_cam[:, 1], y, atol=1e-6)


def test_the_model_holds_what_the_cluttered_cell_says() -> None:
    cell = load_cell(CLUTTERED)
    model = compile_cell(cell)
    sensors = sensors_of(model)
    assert list(sensors) == ["shelf_rgbd", "gripper"]
    for declared in cell.sensors:
        held = sensors[declared.name]
        assert held.mount == declared.mount and held.noise == declared.noise
        assert (held.near, held.far, held.seed) == (declared.near, declared.far, declared.seed)
        assert held.resolution == declared.resolution and held.fovy_deg == declared.fovy_deg
        assert np.allclose(held.position, declared.position)
        # the optical frame: looked at, or read back as a quaternion, the same rotation
        assert np.allclose(held.optical_rotation(), declared.optical_rotation(), atol=1e-5)
    kinds = kinds_of(model)
    assert kinds == cell.objects
    assert [k.name for k in kinds] == [
        "red_can",
        "white_bottle",
        "green_box",
        "black_box",
        "yellow_ball",
    ]
    assert clutter_of(model) == cell.clutter and pick_list_of(model) == ("target", "red_can")
    # every kind pooled: count free bodies of the right shape, size and colour
    for k in kinds:
        for j in range(k.count):
            g = model.geom(f"clutter_{k.name}_{j}")
            assert np.allclose(g.rgba[:3], k.rgb) and model.body_mass[g.bodyid[0]] == k.mass
    box = model.geom("clutter_green_box_0")
    assert np.allclose(box.size, (0.06, 0.04, 0.09))
    # a tidy cell's model has none of it
    published = compile_cell(load_cell(PUBLISHED_CELL))
    assert kinds_of(published) == () and clutter_of(published) is None
    assert pick_list_of(published) == ("target",)


def test_a_sensor_given_by_a_quaternion_is_the_one_given_by_look_at() -> None:
    by_look = parse_cell(PUBLISHED + SENSOR, "a.toml")
    R = by_look.sensors[0].optical_rotation()
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, R.ravel())
    text = SENSOR.replace("look_at = [2.5, 0.0, 1.5]", f"quaternion = {q.tolist()}")
    by_quat = parse_cell(PUBLISHED + text, "b.toml")
    assert np.allclose(by_quat.sensors[0].optical_rotation(), R, atol=1e-12)
    # looking at a point: z points at it, x is level, y points down
    z = np.subtract((2.5, 0.0, 1.5), (0.5, -0.5, 2.0))
    assert np.allclose(R[:, 2], z / np.linalg.norm(z))
    assert abs(R[2, 0]) < 1e-12 and R[2, 1] < 0
    a = sensors_of(compile_cell(by_look))["cam"].optical_rotation()
    b = sensors_of(compile_cell(by_quat))["cam"].optical_rotation()
    assert np.allclose(a, b, atol=1e-6)


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (SENSOR.replace('"cam"', '"Cam 1"'), "[[sensors]] #1 name: expected 1-32 lower-case"),
        (SENSOR.replace('"cam"', '"overview"'), "name: expected not a built-in camera's"),
        (SENSOR + SENSOR, "[[sensors]] #2 name: expected a name no other sensor has"),
        (SENSOR.replace('"cam"', '"gripper"'), "mount: expected 'gripper' for the sensor named"),
        (SENSOR + 'mount = "ceiling"\n', "mount: expected one of 'world', 'gripper'"),
        (SENSOR.replace("look_at = [2.5, 0.0, 1.5]\n", ""), "expected look_at or quaternion"),
        (SENSOR + "quaternion = [1, 0, 0, 0]\n", "look_at or quaternion (one of them), got both"),
        (SENSOR.replace("[2.5, 0.0, 1.5]", "[0.5, -0.5, 1.0]"), "look_at: expected a point"),
        (SENSOR.replace("look_at = [2.5, 0.0, 1.5]", "quaternion = [0, 0, 0, 0]"), "quaternion"),
        (SENSOR + "resolution = [640, 4800]\n", "resolution: expected [width, height]"),
        (SENSOR + "resolution = [640.0, 480]\n", "resolution: expected [width, height]"),
        (SENSOR + "fovy = 180.0\n", "fovy: expected a positive number [deg] from 1 to 170"),
        (SENSOR + "range = [2.0, 1.0]\n", "range: expected [low, high]"),
        (SENSOR + 'noise = "kinect"\n', "noise: expected one of 'none', 'd415', 'd435'"),
        (SENSOR + "seed = -1\n", "seed: expected a whole number"),
        (SENSOR + "colour = 1\n", "[[sensors]] #1 has an unknown key 'colour'"),
        (SENSOR.replace("[[sensors]]", "[sensors]"), "sensors: expected [[sensors]] tables"),
        (KIND.replace('"cylinder"', '"cone"'), "[[objects]] #1 shape: expected one of"),
        (KIND.replace("[0.045, 0.22]", "[0.045]"), "size: expected a list of 2 positive"),
        (KIND.replace("[0.045, 0.22]", "[0.045, 0.9]"), "size: expected a height below"),
        (KIND.replace("[0.045, 0.22]", "[0.3, 0.22]"), "size: expected a footprint narrower"),
        (KIND.replace("[0.045, 0.22]", "[0.005, 0.22]"), "size: expected figures of at least"),
        (KIND.replace("[0.9, 0.1, 0.1]", "[230, 20, 20]"), "color: expected [r, g, b]"),
        (KIND.replace('"red_can"', '"target"'), "name: expected a name no other object kind"),
        (KIND + "mass = 0\n", "mass: expected a positive number [kg]"),
        (KIND + "count = 40\n", "count: expected a whole number from 1 to 12"),
        (KIND + KIND.replace('"red_can"', '"red_can2"'), "color: expected a look of its own"),
        ("[clutter]\nper_bay = [1, 2]\n", "[clutter]: needs [[objects]] kinds"),
        (KIND + "[clutter]\nper_bay = [3, 1]\n", "per_bay: expected [low, high] whole numbers"),
        (KIND + "[clutter]\ngap = [0.0, 0.01]\n", "gap: expected [low, high]"),
        (KIND + '[pick]\norder = ["blue_can"]\n', "order: expected names of object kinds"),
        (KIND + "[pick]\norder = []\n", "order: expected a list of 1 to 64 kind names"),
        (
            KIND.replace("[0.045, 0.22]", "[0.02, 0.22]") + '[pick]\norder = ["red_can"]\n',
            "order: expected kinds the gripper can pick",
        ),
        (
            KIND
            + KIND.replace('"red_can"', '"red_jar"').replace("0.22]", "0.2]")
            + '[pick]\norder = ["red_can", "red_jar"]\n',
            "order: expected kinds of different colours, none the target's",
        ),
        (
            KIND.replace("[0.9, 0.1, 0.1]", "[0.1, 0.35, 0.95]") + '[pick]\norder = ["red_can"]\n',
            "order: expected kinds of different colours, none the target's",
        ),
    ],
)
def test_bad_sensor_and_object_entries_are_one_line_and_exit_2(
    tmp_path: Path, extra: str, message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(PUBLISHED + extra)
    with pytest.raises(ConfigError) as exc:
        load_cell(path)
    assert str(exc.value).startswith(f"{path}: ") and message in str(exc.value), str(exc.value)
    report = tmp_path / "r.json"
    assert main(["run", "--cycles", "1", "--cell", str(path), "--report", str(report)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err
    assert not report.exists()


def test_a_picked_kind_must_count_standing_in_the_bin() -> None:
    text = PUBLISHED.replace("size = [1.0, 1.0, 1.0]", "size = [1.0, 1.0, 0.28]")
    assert text != PUBLISHED
    kind = KIND.replace("[0.045, 0.22]", "[0.045, 0.5]")
    parse_cell(text + kind, "fits.toml")  # a distractor may be that long
    with pytest.raises(ConfigError, match=r"order: expected kinds shorter than 0\.460 m"):
        parse_cell(text + kind + '[pick]\norder = ["red_can"]\n', "long.toml")
