"""A class of original-form submissions, written for these tests: ROS service scripts
``kuka_arm/scripts/IK_server.py`` in Python 2 (print statements, ``xrange``, tabs mixed with
spaces as Python 2 read them), as students of the original exercise wrote them, each laid out as
a repository. None is copied from a public one.

:func:`write_class` writes them into a class folder; :data:`EXPECTED` is each one's verdict.
Most share one closed-form IK (:data:`NUMPY_IK`, NumPy) that keeps the last answer in a global
and picks the solution nearest it; the others make, one each, the mistakes real submissions
made.
"""

from __future__ import annotations

import pickle
from pathlib import Path
from string import Template

#: The exercise's header: what every IK_server.py imports.
HEADER = """#!/usr/bin/env python
# IK server for the KR210 pick and place, written for the kr210_sim tests.
import rospy
import tf
from kuka_arm.srv import *
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
from geometry_msgs.msg import Pose
"""

#: A closed-form IK with NumPy in Python 2 syntax. ``$rpy`` is the rotation from roll, pitch
#: and yaw, ``$a3`` the drop between joints 3 and 4, ``$dg`` the gripper length. The first two
#: lines of ``solve_pose``'s loop body are indented with a tab (column 8 for Python 2, as the
#: eight spaces around them), and the handler mixes a tab and four spaces (column 12).
NUMPY_IK = Template(
    """import numpy as np
from math import atan2, acos, sqrt, pi, cos, sin

LOWER = np.radians([-185, -45, -210, -350, -125, -350])
UPPER = np.radians([185, 85, 65, 350, 125, 350])
DH = [(0, 0, 0.75, 0), (-pi/2, 0.35, 0, -pi/2), (0, 1.25, 0, 0), (-pi/2, -0.054, 1.5, 0),
      (pi/2, 0, 0, 0), (-pi/2, 0, 0, 0)]
A3 = $a3
DG = $dg
PREV_JOINTS = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]

def rot_x(a):
    return np.array([[1, 0, 0], [0, cos(a), -sin(a)], [0, sin(a), cos(a)]])

def rot_y(a):
    return np.array([[cos(a), 0, sin(a)], [0, 1, 0], [-sin(a), 0, cos(a)]])

def rot_z(a):
    return np.array([[cos(a), -sin(a), 0], [sin(a), cos(a), 0], [0, 0, 1]])

R_CORR = rot_z(pi).dot(rot_y(-pi/2))

def link(alpha, a, d, q):
    return np.array([[cos(q), -sin(q), 0, a],
                     [sin(q)*cos(alpha), cos(q)*cos(alpha), -sin(alpha), -sin(alpha)*d],
                     [sin(q)*sin(alpha), cos(q)*sin(alpha), cos(alpha), cos(alpha)*d],
                     [0, 0, 0, 1.0]])

def T0_(q, n):
    T = np.eye(4)
    for i in xrange(n):
        alpha, a, d, offset = DH[i]
        T = T.dot(link(alpha, a, d, q[i] + offset))
    return T

def arms(wc):
    found = []
    for back in (False, True):
        theta1 = atan2(wc[1], wc[0]) + (pi if back else 0)
        if theta1 > pi:
            theta1 -= 2*pi
        rho = sqrt(wc[0]**2 + wc[1]**2) * (-1 if back else 1)
        r, s = rho - 0.35, wc[2] - 0.75
        A, B, C = sqrt(1.5**2 + A3**2), sqrt(r*r + s*s), 1.25
        cos_a = (B*B + C*C - A*A) / (2*B*C)
        cos_b = (A*A + C*C - B*B) / (2*A*C)
        if abs(cos_a) > 1 or abs(cos_b) > 1:
            continue
        a, b = acos(cos_a), acos(cos_b)
        for sign in (1, -1):
            theta2 = pi/2 - sign*a - atan2(s, r)
            theta3 = pi/2 - sign*b - atan2(-A3, 1.5)
            found.append((theta1, theta2, theta3))
            found.append((theta1, theta2, theta3 - 2*pi))
    return found

def solve_pose(p, R_ee):
    global PREV_JOINTS
    R = R_ee.dot(R_CORR)
    wc = p - DG * R[:, 2]
    best = None
    for theta1, theta2, theta3 in arms(wc):
\tq3 = [theta1, theta2, theta3, 0, 0, 0]
\tR3_6 = T0_(q3, 3)[:3, :3].T.dot(R)
        s5 = sqrt(R3_6[0, 2]**2 + R3_6[2, 2]**2)
        if s5 < 1e-9:
            theta4 = PREV_JOINTS[3]
            wrists = [(theta4, atan2(s5, R3_6[1, 2]), atan2(-R3_6[0, 1], R3_6[0, 0]) - theta4)]
        else:
            wrists = [(atan2(R3_6[2, 2], -R3_6[0, 2]), atan2(s5, R3_6[1, 2]),
                       atan2(-R3_6[1, 1], R3_6[1, 0])),
                      (atan2(-R3_6[2, 2], R3_6[0, 2]), atan2(-s5, R3_6[1, 2]),
                       atan2(R3_6[1, 1], -R3_6[1, 0]))]
        for theta4, theta5, theta6 in wrists:
            for k4 in xrange(-2, 3):
                for k6 in xrange(-2, 3):
                    q = np.array([theta1, theta2, theta3, theta4 + 2*pi*k4, theta5,
                                  theta6 + 2*pi*k6])
                    if np.any(q < LOWER - 1e-9) or np.any(q > UPPER + 1e-9):
                        continue
                    d = np.sum((q - PREV_JOINTS)**2)
                    if best is None or d < best[0]:
                        best = (d, q)
    if best is None:
        return None
    PREV_JOINTS = list(best[1])
    return PREV_JOINTS
"""
)

#: The handler: the exercise's template, filled in (``$rpy``: the rotation of the pose).
HANDLER = Template(
    """
def handle_calculate_IK(req):
    rospy.loginfo("Received %s eef-poses from the plan" % len(req.poses))
    if len(req.poses) < 1:
        print "No valid poses received"
        return -1
    else:$setup
\tjoint_trajectory_list = []
        for x in xrange(0, len(req.poses)):
\t    joint_trajectory_point = JointTrajectoryPoint()
            px = req.poses[x].position.x
            py = req.poses[x].position.y
            pz = req.poses[x].position.z
\t    (roll, pitch, yaw) = tf.transformations.euler_from_quaternion(
                [req.poses[x].orientation.x, req.poses[x].orientation.y,
                    req.poses[x].orientation.z, req.poses[x].orientation.w])
            R_ee = $rpy
            q = solve_pose(np.array([px, py, pz]), R_ee)
            if q is None:
                continue
\t    joint_trajectory_point.positions = q
\t    joint_trajectory_list.append(joint_trajectory_point)
        rospy.loginfo("length of Joint Trajectory List: %s" % len(joint_trajectory_list))
        return CalculateIKResponse(joint_trajectory_list)
"""
)

RPY = "rot_z(yaw).dot(rot_y(pitch)).dot(rot_x(roll))"

MAIN = """
def IK_server():
    # initialize node and declare calculate_ik service
    rospy.init_node('IK_server')
    s = rospy.Service('calculate_ik', CalculateIK, handle_calculate_IK)
    print "Ready to receive an IK request"
    rospy.spin()

if __name__ == "__main__":
    IK_server()
"""


def numpy_server(
    rpy: str = RPY, a3: str = "-0.054", dg: str = "0.303", extra: str = "", setup: str = ""
) -> str:
    """The NumPy server with a module-level handler (the exercise's layout); ``setup``: lines
    the handler runs before its loop over the poses."""
    ik = NUMPY_IK.substitute(a3=a3, dg=dg)
    return HEADER + ik + extra + HANDLER.substitute(rpy=rpy, setup=setup) + MAIN


#: A class-based server: the handler is a method of an instance made in ``IK_server()``, and
#: the correction matrix is a global that ``IK_server()`` builds before ``spin()``.
CLASS_BASED = (
    HEADER
    + NUMPY_IK.substitute(a3="-0.054", dg="0.303").replace(
        "R_CORR = rot_z(pi).dot(rot_y(-pi/2))", "R_CORR = None"
    )
    + '''
class KukaIK(object):
    """The server's state lives in the instance."""

    def __init__(self, name):
        self.name = name
        self.requests = 0

    def handle_calculate_IK(self, req):
        self.requests += 1
        points = []
        for pose in req.poses:
            p, o = pose.position, pose.orientation
            roll, pitch, yaw = tf.transformations.euler_from_quaternion([o.x, o.y, o.z, o.w])
            R_ee = rot_z(yaw).dot(rot_y(pitch)).dot(rot_x(roll))
            point = JointTrajectoryPoint()
            point.positions = solve_pose(np.array([p.x, p.y, p.z]), R_ee)
            points.append(point)
        return CalculateIKResponse(points)

def IK_server():
    global R_CORR
    rospy.init_node('IK_server')
    R_CORR = rot_z(pi).dot(rot_y(-pi/2))
    server = KukaIK("kr210")
    rospy.Service('calculate_ik', CalculateIK, server.handle_calculate_IK)
    print "Ready, %s" % server.name
    rospy.spin()

if __name__ == "__main__":
    try:
        IK_server()
    except rospy.ROSInterruptException, e:
        print "interrupted", e
'''
)


def pickle_server() -> str:
    """The NumPy server that reads its gripper length from a pickle beside it, opened in text
    mode as Python 2 allowed."""
    return numpy_server(dg="pickle.load(open('dh_params.pkl'))['dg']", extra="").replace(
        "import numpy as np\n", "import cPickle as pickle\nimport numpy as np\n", 1
    )


#: The sympy server: the symbolic DH chain built for every request (slow), numbers by evalf.
SYMPY_SERVER = (
    HEADER
    + """from mpmath import *
from sympy import *
import numpy as np
"""
    + NUMPY_IK.substitute(a3="-0.054", dg="0.303")
    .split("def solve_pose")[0]
    .replace("import numpy as np\nfrom math import atan2, acos, sqrt, pi, cos, sin\n", "")
    + """
def handle_calculate_IK(req):
    rospy.loginfo("Received %s eef-poses from the plan" % len(req.poses))
    q1, q2, q3 = symbols('q1:4')
    T0_3 = eye(4)
    for i, q in enumerate((q1, q2, q3)):
        alpha, a, d, offset = DH[i]
        T0_3 = T0_3 * Matrix([[cos(q + offset), -sin(q + offset), 0, a],
                              [sin(q + offset)*cos(alpha), cos(q + offset)*cos(alpha),
                               -sin(alpha), -sin(alpha)*d],
                              [sin(q + offset)*sin(alpha), cos(q + offset)*sin(alpha),
                               cos(alpha), cos(alpha)*d],
                              [0, 0, 0, 1]])
    R0_3 = T0_3[0:3, 0:3]
    joint_trajectory_list = []
    for x in xrange(0, len(req.poses)):
        o = req.poses[x].orientation
        (roll, pitch, yaw) = tf.transformations.euler_from_quaternion([o.x, o.y, o.z, o.w])
        R = rot_z(yaw).dot(rot_y(pitch)).dot(rot_x(roll)).dot(rot_z(pi).dot(rot_y(-pi/2)))
        p = req.poses[x].position
        wc = np.array([p.x, p.y, p.z]) - 0.303 * R[:, 2]
        theta1, theta2, theta3 = arms(wc)[0]
        R3_6 = R0_3.evalf(subs={q1: theta1, q2: theta2, q3: theta3}).T * Matrix(R)
        theta4 = atan2(R3_6[2, 2], -R3_6[0, 2])
        theta5 = atan2(sqrt(R3_6[0, 2]**2 + R3_6[2, 2]**2), R3_6[1, 2])
        theta6 = atan2(-R3_6[1, 1], R3_6[1, 0])
        point = JointTrajectoryPoint()
        point.positions = [theta1, theta2, theta3, theta4, theta5, theta6]
        joint_trajectory_list.append(point)
    return CalculateIKResponse(joint_trajectory_list)
"""
    + MAIN
)


#: The exercise's template filled in with sympy, as most did: the DH chain and the corrected
#: rotation built symbolically for every request, the numbers substituted pose by pose.
#: ``$wc`` is the wrist centre, ``$r36`` the rotation R3_6.
SYMPY_TEMPLATE = Template(
    HEADER
    + """from mpmath import *
from sympy import *

def handle_calculate_IK(req):
    rospy.loginfo("Received %s eef-poses from the plan" % len(req.poses))
    if len(req.poses) < 1:
        print "No valid poses received"
        return -1
    q1, q2, q3 = symbols('q1:4')
    s = {q1: q1, q2: q2 - pi/2, q3: q3}
    def TF(alpha, a, d, q):
        return Matrix([[cos(q), -sin(q), 0, a],
                       [sin(q)*cos(alpha), cos(q)*cos(alpha), -sin(alpha), -sin(alpha)*d],
                       [sin(q)*sin(alpha), cos(q)*sin(alpha), cos(alpha), cos(alpha)*d],
                       [0, 0, 0, 1]])
    T0_1 = TF(0, 0, 0.75, q1).subs(s)
    T1_2 = TF(-pi/2, 0.35, 0, q2).subs(s)
    T2_3 = TF(0, 1.25, 0, q3).subs(s)
    R0_3 = T0_1[0:3, 0:3] * T1_2[0:3, 0:3] * T2_3[0:3, 0:3]
    r, p, y = symbols('r p y')
    ROT_x = Matrix([[1, 0, 0], [0, cos(r), -sin(r)], [0, sin(r), cos(r)]])
    ROT_y = Matrix([[cos(p), 0, sin(p)], [0, 1, 0], [-sin(p), 0, cos(p)]])
    ROT_z = Matrix([[cos(y), -sin(y), 0], [sin(y), cos(y), 0], [0, 0, 1]])
    ROT_EE = ROT_z * ROT_y * ROT_x * ROT_z.subs(y, radians(180)) * ROT_y.subs(p, radians(-90))
    joint_trajectory_list = []
    for x in xrange(0, len(req.poses)):
        joint_trajectory_point = JointTrajectoryPoint()
        px = req.poses[x].position.x
        py = req.poses[x].position.y
        pz = req.poses[x].position.z
        (roll, pitch, yaw) = tf.transformations.euler_from_quaternion(
            [req.poses[x].orientation.x, req.poses[x].orientation.y,
                req.poses[x].orientation.z, req.poses[x].orientation.w])
        R_EE = ROT_EE.subs({'r': roll, 'p': pitch, 'y': yaw})
        EE = Matrix([[px], [py], [pz]])
        WC = $wc
        theta1 = atan2(WC[1], WC[0])
        side_a = 1.501
        side_b = sqrt(pow((sqrt(WC[0]*WC[0] + WC[1]*WC[1]) - 0.35), 2) + pow((WC[2] - 0.75), 2))
        side_c = 1.25
        angle_a = acos((side_b*side_b + side_c*side_c - side_a*side_a) / (2*side_b*side_c))
        angle_b = acos((side_a*side_a + side_c*side_c - side_b*side_b) / (2*side_a*side_c))
        theta2 = pi/2 - angle_a - atan2(WC[2] - 0.75, sqrt(WC[0]*WC[0] + WC[1]*WC[1]) - 0.35)
        theta3 = pi/2 - (angle_b + 0.036)
        R3_6 = $r36
        theta4 = atan2(R3_6[2, 2], -R3_6[0, 2])
        theta5 = atan2(sqrt(R3_6[0, 2]*R3_6[0, 2] + R3_6[2, 2]*R3_6[2, 2]), R3_6[1, 2])
        theta6 = atan2(-R3_6[1, 1], R3_6[1, 0])
        joint_trajectory_point.positions = [theta1, theta2, theta3, theta4, theta5, theta6]
        joint_trajectory_list.append(joint_trajectory_point)
    rospy.loginfo("length of Joint Trajectory List: %s" % len(joint_trajectory_list))
    return CalculateIKResponse(joint_trajectory_list)
"""
    + MAIN
)
WC = "EE - 0.303 * R_EE[:, 2]"
R36 = "R0_3.evalf(subs={q1: theta1, q2: theta2, q3: theta3}).transpose() * R_EE"

#: The NumPy server checking each answer with a symbolic forward kinematics that
#: ``IK_server()`` builds before ``spin()`` (a global): slow, as such checks were.
SLOW_SYMPY = (
    numpy_server(
        extra="""
from sympy import symbols, Matrix, cos as scos, sin as ssin, pi as spi
SYMBOLIC_DH = [(0, 0, 0.75, 0), (-spi/2, 0.35, 0, -spi/2), (0, 1.25, 0, 0),
               (-spi/2, -0.054, 1.5, 0), (spi/2, 0, 0, 0), (-spi/2, 0, 0, 0)]
T_TOTAL = None
QS = None

def symbolic_fk():
    qs = symbols('q1:7')
    T = Matrix.eye(4)
    for i in xrange(6):
        alpha, a, d, offset = SYMBOLIC_DH[i]
        q = qs[i] + offset
        T = T * Matrix([[scos(q), -ssin(q), 0, a],
                        [ssin(q)*scos(alpha), scos(q)*scos(alpha), -ssin(alpha), -ssin(alpha)*d],
                        [ssin(q)*ssin(alpha), scos(q)*ssin(alpha), scos(alpha), scos(alpha)*d],
                        [0, 0, 0, 1]])
    return qs, T * Matrix([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, DG], [0, 0, 0, 1]])
"""
    )
    .replace(
        "\t    joint_trajectory_point.positions = q",
        "            T = T_TOTAL.evalf(subs=dict(zip(QS, q)))\n"
        "            print 'pose %d: end effector error %.2e m' % (x, sqrt((T[0, 3] - px)**2"
        " + (T[1, 3] - py)**2 + (T[2, 3] - pz)**2))\n"
        "\t    joint_trajectory_point.positions = q",
    )
    .replace(
        "    rospy.init_node('IK_server')\n",
        "    global T_TOTAL, QS\n"
        "    rospy.init_node('IK_server')\n"
        "    QS, T_TOTAL = symbolic_fk()\n",
    )
)


def _server(source: str) -> dict[str, str]:
    return {"kuka_arm/scripts/IK_server.py": source}


def submissions() -> dict[str, dict[str, str]]:
    """Each student's repository: file path -> text."""
    stale = numpy_server(  # the rotation substituted in place: the first pose's for all
        rpy="np.array(R_rpy.evalf(), dtype=float)",
        extra="\nfrom sympy import symbols, Matrix, cos as scos, sin as ssin\n",
        setup="""
        r, p, y = symbols('r p y')
        R_rpy = (Matrix([[scos(y), -ssin(y), 0], [ssin(y), scos(y), 0], [0, 0, 1]])
                 * Matrix([[scos(p), 0, ssin(p)], [0, 1, 0], [-ssin(p), 0, scos(p)]])
                 * Matrix([[1, 0, 0], [0, scos(r), -ssin(r)], [0, ssin(r), scos(r)]]))""",
    ).replace(
        "            R_ee = np.array(R_rpy.evalf()",
        "            R_rpy = R_rpy.subs({r: roll, p: pitch, y: yaw})\n"
        "            R_ee = np.array(R_rpy.evalf()",
    )
    leaks = numpy_server().replace(  # relies on Python 2's leaking comprehension variable
        "\t    joint_trajectory_point.positions = q",
        "            angles = [round(a, 12) for a in q]\n"
        "\t    joint_trajectory_point.positions = angles[:5] + [a]",
    )
    return {
        "alice": _server(numpy_server()),
        "dave": _server(SLOW_SYMPY),
        "ivan": _server(SYMPY_TEMPLATE.substitute(wc="EE + 0.303 * R_EE[:, 2]", r36=R36)),
        "judy": _server(SYMPY_TEMPLATE.substitute(wc=WC, r36="R0_3.transpose() * R_EE")),
        "oscar": _server(leaks),
        "bob": _server(CLASS_BASED),
        "carol": {
            **_server(pickle_server()),
            "kuka_arm/scripts/dh_params.pkl": "",  # written as bytes by write_class
        },
        "erin": _server(
            numpy_server().replace(
                "            q = solve_pose(np.array([px, py, pz]), R_ee)",
                "            # q = solve_pose(np.array([px, py, pz]), R_ee)",
            )
        ),
        "frank": _server(stale),
        "grace": _server(numpy_server(rpy="rot_x(roll).dot(rot_y(pitch)).dot(rot_z(yaw))")),
        "heidi": _server(numpy_server(a3="0.0")),
        "mallory": _server(numpy_server(dg="303/1000")),
        "peggy": _server(
            numpy_server().replace("import rospy\n", "import rospy\nimport moveit_commander\n")
        ),
        "trent": _server(
            numpy_server().replace(
                "        r, s = rho - 0.35,",
                "        r, s = rho - 0.35,\n        theta2 =\n       ",
            )
        ),
    }


#: Each student's verdict when the class is graded.
EXPECTED = {
    "alice": "pass",
    "dave": "pass",
    "ivan": "fail",
    "judy": "fail",
    "oscar": "pass",
    "bob": "pass",
    "carol": "pass",
    "erin": "fail",
    "frank": "fail",
    "grace": "fail",
    "heidi": "fail",
    "mallory": "fail",
    "peggy": "error",
    "trent": "error",
}


def write_class(folder: Path, names: tuple[str, ...] | None = None) -> Path:
    """Write the class (or the students ``names``) into ``folder``, one repository each."""
    for name, files in submissions().items():
        if names is not None and name not in names:
            continue
        for rel, text in files.items():
            path = folder / name / rel
            path.parent.mkdir(parents=True, exist_ok=True)
            if rel.endswith(".pkl"):
                path.write_bytes(pickle.dumps({"dg": 0.303}, protocol=2))
            else:
                path.write_text(text)
    return folder


def _stateless(source: str) -> str:
    """``source`` with the answer nearest a fixed reference (zeros), not the last answer: the
    same answer for the same pose whatever came before."""
    return source.replace(
        "    PREV_JOINTS = list(best[1])\n    return PREV_JOINTS", "    return list(best[1])"
    )


def cross_check() -> tuple[str, str]:
    """One IK written twice: as an original-form ROS server (Python 2) and in our contract
    (``solve(T, q_ref)``, Python 3), for the same answers and verdicts."""
    ros = _stateless(numpy_server())
    ik = _stateless(NUMPY_IK.substitute(a3="-0.054", dg="0.303"))
    ours = ik.replace("xrange", "range").replace("\t", " " * 8) + (
        "\n\ndef solve(T, q_ref):\n    return solve_pose(T[:3, 3], T[:3, :3])\n"
    )
    return ros, ours


def sleeping_server(seconds: float) -> str:
    """A correct server (the NumPy one: the grader's own IK is not in its jail) that sleeps
    ``seconds`` a pose: slow whatever the machine's load, for the tests of the time budget."""
    return numpy_server(rpy=f"(__import__('time').sleep({seconds!r}), {RPY})[1]")
