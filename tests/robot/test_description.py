"""The robot description: the URDF read with the standard library agrees with yourdfpy, and bad
content is one clear SceneError."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from kr210_sim.errors import SceneError
from kr210_sim.robot.description import _origin, load_robot
from kr210_sim.util.paths import URDF_PATH


def test_every_joint_as_yourdfpy_reads_it() -> None:
    import yourdfpy

    urdf = yourdfpy.URDF.load(
        str(URDF_PATH),
        load_meshes=False,
        build_scene_graph=False,
        build_collision_scene_graph=False,
    )
    robot = load_robot()
    assert list(robot.joints) == [j.name for j in urdf.robot.joints]
    for j in urdf.robot.joints:
        ours = robot.joints[j.name]
        assert (ours.parent, ours.child) == (j.parent, j.child)
        np.testing.assert_array_equal(ours.origin, j.origin)
        if j.type == "fixed":
            np.testing.assert_array_equal(ours.axis, np.zeros(3))
        else:
            np.testing.assert_array_equal(ours.axis, j.axis)
        if j.limit is not None:
            lim = (j.limit.lower, j.limit.upper, j.limit.velocity, j.limit.effort)
            assert (ours.lower, ours.upper, ours.velocity, ours.effort) == lim
    assert robot.finger_gap_at_zero == pytest.approx(0.119)
    assert (robot.lip_x, robot.lip_depth, robot.finger_center_x) == pytest.approx(
        (0.215, 0.018, 0.15)
    )


def test_origin_is_rz_ry_rx() -> None:
    from xml.etree import ElementTree

    r, p, y = 0.3, -1.1, 2.5
    element = ElementTree.fromstring(f'<origin xyz="1 -2 0.5" rpy="{r} {p} {y}"/>')
    c, s = math.cos, math.sin
    Rx = np.array([[1, 0, 0], [0, c(r), -s(r)], [0, s(r), c(r)]])
    Ry = np.array([[c(p), 0, s(p)], [0, 1, 0], [-s(p), 0, c(p)]])
    Rz = np.array([[c(y), -s(y), 0], [s(y), c(y), 0], [0, 0, 1]])
    T = _origin(Path("x.urdf"), element)
    np.testing.assert_allclose(T[:3, :3], Rz @ Ry @ Rx, atol=1e-15)
    np.testing.assert_array_equal(T[:3, 3], [1.0, -2.0, 0.5])
    np.testing.assert_array_equal(_origin(Path("x.urdf"), None), np.eye(4))


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        (
            '<origin xyz="0 0 1.25"',
            '<origin xyz="0 zero 1.25"',
            "xyz='0 zero 1.25' is not 3 numbers",
        ),
        ('<origin xyz="0 0 1.25" rpy="0 0 0"', '<origin xyz="0 0 1.25" rpy="0 0.1 0"', "rpy = 0"),
        ('<joint name="joint_6"', '<joint name="joint_66"', "lacks joints ['joint_6']"),
        ('<robot name="kr210">', '<robot name="kr210"><robot/>', ""),
    ],
)
def test_bad_urdf_content_is_one_scene_error(
    tmp_path: Path, old: str, new: str, message: str
) -> None:
    text = URDF_PATH.read_text()
    origin_3 = load_robot().joints["joint_3"].origin
    assert text.count(old) >= 1
    bad = tmp_path / "kr210.urdf"
    bad.write_text(text.replace(old, new, 1))
    if not message:  # a harmless change: still a KR210
        np.testing.assert_array_equal(load_robot(bad).joints["joint_3"].origin, origin_3)
        assert load_robot(bad).geometry == load_robot().geometry  # read twice, equal by value
        return
    with pytest.raises(SceneError) as err:
        load_robot(bad)
    assert message in str(err.value) and "\n" not in str(err.value)


def test_a_root_other_than_robot_is_refused(tmp_path: Path) -> None:
    bad = tmp_path / "kr210.urdf"
    bad.write_text("<sdf><joint name='joint_1'/></sdf>")
    with pytest.raises(SceneError, match="the root element is <sdf>, not <robot>"):
        load_robot(bad)
