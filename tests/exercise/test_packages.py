"""The student's own message and service types, made from the ``.msg`` and ``.srv`` files of the
catkin packages in their repository, as genpy made them."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from kr210_sim.errors import IkSpecError
from kr210_sim.exercise.packages import msg_module, package_folders, parse, srv_module
from kr210_sim.exercise.server import RosServer
from kr210_sim.robot.description import load_robot
from kr210_sim.robot.kinematics import Kinematics

KIN = Kinematics(load_robot())


def test_a_definition_is_read_as_genpy_read_it() -> None:
    fields, constants = parse(
        "# the errors of one request\nfloat64[] data  # [m]\nint32 MAX=8\n"
        "string LABEL=ee # not a comment\nHeader header\ngeometry_msgs/Pose[3] poses\n",
        "Errors.msg",
    )
    assert fields == [
        ("float64[]", "data"),
        ("Header", "header"),
        ("geometry_msgs/Pose[3]", "poses"),
    ]
    assert constants == {"MAX": 8, "LABEL": "ee # not a comment"}
    with pytest.raises(IkSpecError, match=r"Bad.msg line 2: cannot read 'float64' as a field"):
        parse("int8 a\nfloat64\n", "Bad.msg")


def _package(root: Path, name: str = "kuka_arm") -> Path:
    pkg = root / name
    (pkg / "msg").mkdir(parents=True)
    (pkg / "srv").mkdir()
    (pkg / "scripts").mkdir()
    (pkg / "package.xml").write_text(f"<package>\n  <name>{name}</name>\n</package>\n")
    (pkg / "msg" / "Float64List.msg").write_text("float64[] data\n")
    (pkg / "msg" / "Report.msg").write_text("Header header\nFloat64List errors\nuint8 OK=1\n")
    (pkg / "srv" / "Scale.srv").write_text("float64 factor\n---\nbool done\nstring why\n")
    return pkg


def test_messages_and_services_of_a_package(tmp_path: Path) -> None:
    pkg = _package(tmp_path, "arm_extras")
    msg = msg_module("arm_extras.msg", pkg)
    report = msg.Report()  # built after Float64List, which it names
    assert report.errors == msg.Float64List() and report.OK == 1
    assert msg.Float64List(data=[1.0, 2.0]).data == [1.0, 2.0]
    assert str(msg.Float64List([0.5])) == "data: [0.5]"
    srv = srv_module("arm_extras.srv", pkg)
    assert srv.Scale._request_class is srv.ScaleRequest
    assert srv.ScaleRequest().factor == 0.0
    assert srv.ScaleResponse(done=True).why == ""


def test_the_packages_beside_the_script_are_found(tmp_path: Path) -> None:
    _package(tmp_path)
    other = tmp_path / "shelf_msgs"
    (other / "msg").mkdir(parents=True)
    (tmp_path / "kuka_gazebo").mkdir()  # no messages: not a message package
    found = package_folders(tmp_path / "kuka_arm" / "scripts" / "IK_server.py")
    assert found == {"kuka_arm": tmp_path / "kuka_arm", "shelf_msgs": other}


#: A server that publishes its errors as a message of its own package, and reads a constant of
#: another package's message.
SERVER = """import rospy
from kuka_arm.srv import *
from kuka_arm.msg import Float64List
from shelf_msgs.msg import Shelf
from trajectory_msgs.msg import JointTrajectoryPoint

def handle_calculate_IK(req):
    points = []
    for pose in req.poses:
        point = JointTrajectoryPoint()
        point.positions = [pose.position.x, Shelf.ROWS, 0, 0, 0, 0]
        points.append(point)
    pub.publish(Float64List(data=[0.0] * len(points)))
    return CalculateIKResponse(points)

def IK_server():
    global pub
    pub = rospy.Publisher('ee_error', Float64List, queue_size=2)
    rospy.init_node('IK_server')
    rospy.Service('calculate_ik', CalculateIK, handle_calculate_IK)
    rospy.spin()

if __name__ == "__main__":
    IK_server()
"""


def test_a_server_imports_its_repository_s_own_messages(tmp_path: Path) -> None:
    pkg = _package(tmp_path)
    (tmp_path / "shelf_msgs" / "msg").mkdir(parents=True)
    (tmp_path / "shelf_msgs" / "msg" / "Shelf.msg").write_text("int32 ROWS=3\nfloat64 pitch\n")
    script = pkg / "scripts" / "IK_server.py"
    script.write_text(SERVER)
    server = RosServer(script, f"{script}:handle_calculate_IK", "handle_calculate_IK")
    server.start()
    T = KIN.forward(np.zeros(6))
    (answer,) = server.batch([T])
    assert answer[:2] == pytest.approx([T[0, 3], 3.0])
    import kuka_arm.srv  # type: ignore[import-not-found]  # still ours: the exercise's service

    assert kuka_arm.srv.CalculateIK._type == "kuka_arm/CalculateIK"


def test_a_package_with_no_messages_is_still_one_line(tmp_path: Path) -> None:
    script = tmp_path / "IK_server.py"
    script.write_text("import rospy\nfrom nowhere_msgs.msg import Thing\n")
    server = RosServer(script, f"{script}:handle_calculate_IK", "handle_calculate_IK")
    with pytest.raises(IkSpecError, match=r"imports nowhere_msgs, a ROS package .* own catkin"):
        server.start()


def test_a_sandbox_may_read_the_definitions_and_no_more(tmp_path: Path) -> None:
    from kr210_sim.sandbox.user_ik import spec_files

    pkg = _package(tmp_path)
    (pkg / "urdf").mkdir()
    script = pkg / "scripts" / "IK_server.py"
    script.write_text(SERVER)
    readable = spec_files(f"{script}:handle_calculate_IK").readable
    assert set(readable) == {
        pkg / "scripts",
        pkg / "msg",
        pkg / "srv",
        pkg / "package.xml",
    }


def test_a_huge_package_xml_is_not_read_whole(tmp_path: Path) -> None:
    """A sparse 3 GB ``package.xml`` beside a ``msg`` folder, in a process of at most 2 GB
    of address space: named in one line, not read (it was read whole, 6.2 GB RSS)."""
    pkg = _package(tmp_path)
    with open(pkg / "package.xml", "r+b") as f:
        f.truncate(3 << 30)
    script = pkg / "scripts" / "IK_server.py"
    script.write_text(SERVER)
    code = (
        "import resource, sys; from pathlib import Path\n"
        "resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))\n"
        "from kr210_sim.errors import IkSpecError\n"
        "from kr210_sim.exercise.packages import package_folders\n"
        "try:\n    package_folders(Path(sys.argv[1]))\n"
        "except IkSpecError as exc:\n    print(exc)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code, str(script)],
        capture_output=True,
        text=True,
        timeout=120,
        env=dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MUJOCO_GL="disable"),
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout == (
        f"{pkg / 'package.xml'} holds 3,221,225,472 bytes, more than the 1,048,576 read: "
        "not read (a package.xml is a few kB)\n"
    )
