"""A ROS-form server run as ROS ran it: as ``__main__``, served from ``rospy.spin()`` (its locals,
globals and instances alive, one process for every request), requests of many poses, a pose
that raises losing no other, and the import failures as one line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from kr210_sim.errors import IkSpecError
from kr210_sim.exercise.server import RosServer
from kr210_sim.robot.description import load_robot
from kr210_sim.robot.kinematics import Kinematics

KIN = Kinematics(load_robot())


def _pose(i: int) -> np.ndarray:
    T = KIN.forward(np.array([0.0, 0.2, -0.1, 0.3, 0.5, 0.1]))
    T[0, 3] = 1.5 + 0.1 * i
    return T


#: Poses whose x position says which they are (1.5 m + 0.1 m each).
POSES = [_pose(i) for i in range(5)]

HEAD = """import rospy
from kuka_arm.srv import *
from trajectory_msgs.msg import JointTrajectoryPoint
"""
#: A handler answering each pose with its position and a request counter.
ECHO = """
REQUESTS = []

def handle_calculate_IK(req):
    REQUESTS.append(len(req.poses))
    points = []
    for x in xrange(len(req.poses)):
        p = req.poses[x].position
        point = JointTrajectoryPoint()
        point.positions = [p.x, p.y, p.z, len(REQUESTS), 0, 0]
        points.append(point)
    return CalculateIKResponse(points)
"""
MAIN = """
def IK_server():
    rospy.init_node('IK_server')
    rospy.Service('calculate_ik', CalculateIK, handle_calculate_IK)
    print "Ready to receive an IK request"
    rospy.spin()

if __name__ == "__main__":
    IK_server()
"""


def serve(tmp_path: Path, source: str, name: str = "IK_server.py") -> RosServer:
    path = tmp_path / name
    path.write_text(source)
    server = RosServer(path, f"{path}:handle_calculate_IK", "handle_calculate_IK")
    server.start()
    return server


def test_one_request_for_many_poses_and_globals_persist(tmp_path: Path) -> None:
    server = serve(tmp_path, HEAD + ECHO + MAIN)
    first = server.batch(POSES)
    assert [a[0] for a in first] == pytest.approx([T[0, 3] for T in POSES])
    assert {a[3] for a in first} == {1.0}  # one request
    (again,) = server.batch(POSES[:1])
    assert again[3] == 2.0  # the same process and globals: the second request
    assert server.solve(POSES[2], np.zeros(6))[0] == pytest.approx(POSES[2][0, 3])
    assert server.module is not None and server.module.__name__ == "__main__"
    assert server.module.REQUESTS == [5, 1, 1]


def test_a_class_based_server_keeps_its_instance_and_what_ik_server_built(tmp_path: Path) -> None:
    """The handler is a bound method; the scale a local of IK_server(), built before spin()."""
    source = HEAD + (
        "class Server(object):\n"
        "    def __init__(self, scale):\n"
        "        self.scale = scale\n"
        "        self.calls = 0\n"
        "    def handle(self, req):\n"
        "        self.calls += 1\n"
        "        out = []\n"
        "        for pose in req.poses:\n"
        "            point = JointTrajectoryPoint()\n"
        "            point.positions = [pose.position.x * self.scale, self.calls, 0, 0, 0, 0]\n"
        "            out.append(point)\n"
        "        return CalculateIKResponse(out)\n"
        "def IK_server():\n"
        "    scale = 2.0\n"
        "    server = Server(scale)\n"
        "    rospy.Service('calculate_ik', CalculateIK, server.handle)\n"
        "    rospy.spin()\n"
        "IK_server()\n"
    )
    server = serve(tmp_path, source)
    server.batch(POSES)
    a, b = server.batch(POSES[:2])
    assert a[0] == pytest.approx(2 * POSES[0][0, 3]) and a[1] == b[1] == 2.0


def test_what_is_served_without_spin(tmp_path: Path) -> None:
    """A script that registers and ends is served by its handler; one that registers nothing by
    its module-level handle_calculate_IK; a loop on is_shutdown() serves as spin() does."""
    registered = HEAD + ECHO + "rospy.Service('calculate_ik', CalculateIK, handle_calculate_IK)\n"
    assert serve(tmp_path, registered).batch(POSES[:1])[0][3] == 1.0
    assert serve(tmp_path, HEAD + ECHO, "plain.py").batch(POSES[:1])[0][3] == 1.0
    loop = (
        HEAD
        + ECHO
        + (
            "rospy.Service('calculate_ik', CalculateIK, handle_calculate_IK)\n"
            "rate = rospy.Rate(10)\n"
            "while not rospy.is_shutdown():\n"
            "    rate.sleep()\n"
        )
    )
    assert serve(tmp_path, loop, "loop.py").batch(POSES[:1])[0][3] == 1.0
    with pytest.raises(IkSpecError, match=r"registered no service with rospy.Service"):
        serve(tmp_path, HEAD + "x = 1\n", "nothing.py")


#: A handler that raises on the pose whose x is above 0.25 m past the first pose's.
RAISES = """
REQUESTS = []

def handle_calculate_IK(req):
    REQUESTS.append([round(p.position.x, 3) for p in req.poses])
    points = []
    for x in xrange(len(req.poses)):
        p = req.poses[x].position
        if abs(p.x - FIRST) > 0.25 and abs(p.x - FIRST) < 0.35:
            theta = undefined_name
        point = JointTrajectoryPoint()
        point.positions = [p.x, 0, 0, 0, 0, 0]
        points.append(point)
    $after
    return CalculateIKResponse(points)
"""


def test_a_pose_that_raises_loses_no_other(tmp_path: Path) -> None:
    """The pose read when the handler raised gets the exception (with the student's line); the
    poses before and after it are asked again, in a request each side."""
    first = f"FIRST = {float(POSES[0][0, 3])!r}\n"
    server = serve(tmp_path, HEAD + first + RAISES.replace("$after", "pass") + MAIN)
    answers = server.batch(POSES)
    assert [isinstance(a, Exception) for a in answers] == [False, False, False, True, False]
    err = answers[3]
    assert type(err).__name__ == "NameError"
    assert str(err) == "name 'undefined_name' is not defined (IK_server.py line 14)"
    xs = [round(T[0, 3], 3) for T in POSES]
    assert server.module is not None
    assert server.module.REQUESTS == [xs, xs[:3], xs[4:]]
    with pytest.raises(NameError):
        server.solve(POSES[3], np.zeros(6))


def test_a_raise_after_every_pose_was_read_asks_each_pose_alone(tmp_path: Path) -> None:
    after = "if len(req.poses) > 1: raise RuntimeError('only one at a time')"
    first = f"FIRST = {float(POSES[0][0, 3]) - 1.0!r}\n"
    server = serve(tmp_path, HEAD + first + RAISES.replace("$after", after) + MAIN)
    answers = server.batch(POSES[:3])
    assert all(isinstance(a, list) for a in answers)
    assert server.module is not None and [len(r) for r in server.module.REQUESTS] == [3, 1, 1, 1]


def test_a_pose_skipped_with_continue_has_no_answer(tmp_path: Path) -> None:
    """Fewer points than poses: each pose is asked alone; the one with no point is None."""
    source = HEAD + (
        f"FIRST = {float(POSES[0][0, 3])!r}\n"
        "def handle_calculate_IK(req):\n"
        "    points = []\n"
        "    for pose in req.poses:\n"
        "        if abs(pose.position.x - FIRST - 0.1) < 0.01:\n"
        "            continue\n"
        "        point = JointTrajectoryPoint()\n"
        "        point.positions = [pose.position.x, 0, 0, 0, 0, 0]\n"
        "        points.append(point)\n"
        "    return CalculateIKResponse(points)\n"
    )
    answers = serve(tmp_path, source).batch(POSES[:3])
    assert answers[1] is None and answers[0] is not None and answers[2] is not None


def test_sympy_answers_are_converted_and_the_unusable_ones_say_why(tmp_path: Path) -> None:
    source = HEAD + (
        "from sympy import *\n"
        "q4 = symbols('q4')\n"
        "def handle_calculate_IK(req):\n"
        "    points = []\n"
        "    for i in xrange(len(req.poses)):\n"
        "        point = JointTrajectoryPoint()\n"
        "        if i == 0:\n"
        "            point.positions = [pi/2, Float(0.25), Rational(1, 4), sqrt(2), 0, 1]\n"
        "        elif i == 1:\n"
        "            point.positions = [acos(Float(1.02)) + 1, 0, 0, 0, 0, 0]\n"
        "        else:\n"
        "            point.positions = [0, 0, 0, atan2(q4, 1) + 0.5, 0, 0]\n"
        "        points.append(point)\n"
        "    return CalculateIKResponse(points)\n"
    )
    good, complex_, symbolic = serve(tmp_path, source).batch(POSES[:3])
    assert good == pytest.approx([np.pi / 2, 0.25, 0.25, np.sqrt(2), 0, 1])
    assert all(type(v) is float for v in good)
    with pytest.raises(TypeError, match=r"joint_1 = 1\+0.2j: acos or asin of a value beyond"):
        np.asarray(complex_)
    assert type(complex_).__name__ == "a complex number"
    assert type(symbolic).__name__ == "an unevaluated sympy expression"
    with pytest.raises(TypeError, match=r"joint_4 = atan2\(q4, 1\) \+ 0.5 has free symbols q4"):
        float(symbolic)


def test_what_rospy_refused_is_every_poses_error(tmp_path: Path) -> None:
    source = HEAD + "def handle_calculate_IK(req):\n    return -1\n"
    answers = serve(tmp_path, source).batch(POSES[:2])
    assert all(isinstance(a, Exception) for a in answers)
    assert "response holds -1 for its points" in str(answers[0])


def test_a_ros_package_that_is_not_here_is_one_line(tmp_path: Path) -> None:
    with pytest.raises(IkSpecError) as err:
        serve(tmp_path, "import rospy\nimport moveit_commander\n" + ECHO)
    assert str(err.value).endswith(
        "IK_server.py line 2 imports moveit_commander, a ROS package kr210_sim does not provide "
        "(it provides rospy, tf, tf2_ros, kuka_arm.srv, geometry_msgs.msg, std_msgs.msg, "
        "trajectory_msgs.msg, sensor_msgs.msg, visualization_msgs.msg, roslib, and the .msg and "
        ".srv types of the repository's own catkin packages)"
    )
    with pytest.raises(
        IkSpecError, match=r"line 1 imports no_such_lib_here, which is not installed"
    ):
        serve(tmp_path, "import no_such_lib_here\n" + ECHO, "b.py")
    with pytest.raises(
        IkSpecError, match=r"running c.py raised ZeroDivisionError: .* \(c.py line 2\)"
    ):
        serve(tmp_path, "x = 1\ny = x / 0\n", "c.py")


def test_the_students_own_python_2_modules_are_read_as_python_2(tmp_path: Path) -> None:
    """A module beside the script and a package in the catkin package's src folder, Python 2
    both (an implicit relative import inside the package), nothing written beside them."""
    (tmp_path / "scripts").mkdir()
    (tmp_path / "src" / "kinematics").mkdir(parents=True)
    (tmp_path / "scripts" / "helper.py").write_text(
        "def scale():\n    print 'scale'\n    return 1/2\n"
    )
    (tmp_path / "src" / "kinematics" / "__init__.py").write_text("")
    (tmp_path / "src" / "kinematics" / "consts.py").write_text("OFFSET = 3\n")
    (tmp_path / "src" / "kinematics" / "ik.py").write_text(
        "import consts\ndef offset():\n    return consts.OFFSET\n"
    )
    source = HEAD + (
        "from helper import scale\nfrom kinematics.ik import offset\n"
        + ECHO.replace("p.x, p.y, p.z", "scale(), offset(), p.z")
    )
    server = serve(tmp_path / "scripts", source)
    assert server.batch(POSES[:1])[0][:2] == [0.0, 3.0]
    assert not list(tmp_path.rglob("__pycache__"))


def test_sys_exit_in_the_handler_ends_the_process(tmp_path: Path) -> None:
    source = HEAD + "import sys\ndef handle_calculate_IK(req):\n    sys.exit(4)\n"
    with pytest.raises(SystemExit):
        serve(tmp_path, source).batch(POSES[:2])


def test_the_ros_modules_import_as_servers_imported_them(tmp_path: Path) -> None:
    """Every spelling the servers used: the shims are real modules on the path."""
    source = (
        "import rospy, roslib\n"
        "roslib.load_manifest('kuka_arm')\n"
        "import tf, tf2_ros\n"
        "import tf.transformations as tft\n"
        "from tf.transformations import euler_from_quaternion, _AXES2TUPLE\n"
        "from tf import transformations\n"
        "from rospy.exceptions import ROSException\n"
        "from kuka_arm.srv import CalculateIK, CalculateIKRequest, CalculateIKResponse\n"
        "from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint\n"
        "from geometry_msgs.msg import Pose, Point, Quaternion, TransformStamped\n"
        "import geometry_msgs.msg\n"
        "from std_msgs.msg import Float64, String, Header\n"
        "from sensor_msgs.msg import JointState\n"
        "from visualization_msgs.msg import Marker, MarkerArray\n"
        "assert tft is transformations and len(_AXES2TUPLE) == 24\n"
        "assert euler_from_quaternion([0, 0, 0, 1]) == (0.0, 0.0, 0.0)\n"
        "t = geometry_msgs.msg.Transform()\n"
        "broadcaster = tf2_ros.TransformBroadcaster()\n"
        "listener = tf.TransformListener()\n"
        "start = rospy.Time.now().to_sec()\n" + ECHO
    )
    assert serve(tmp_path, source).batch(POSES[:1])[0][3] == 1.0
