"""The guard's batches (sandbox/ik_guard.py): a batch-taking IK, a ROS-form server, is asked an
ik-check's cases and each straight line's samples in one request, and judged as any IK."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from kr210_sim.grading.ikcheck import run_check
from kr210_sim.plan.trajectory import line_poses
from kr210_sim.robot import kinematics
from kr210_sim.sandbox.ik_guard import BATCH, CheckedIk, call_many
from kr210_sim.sandbox.user_ik import UserIk, load_ik
from kr210_sim.sim.runner import RunConfig, Runner
from kr210_sim.sim.session import run_session

#: A ROS-form server answering with our IK (nearest its previous answer), counting requests.
SERVER = """import rospy
from kuka_arm.srv import *
from trajectory_msgs.msg import JointTrajectoryPoint
import numpy as np
from kr210_sim.robot import kinematics
from kr210_sim.robot.quaternions import pose_matrix

REQUESTS = []
PREV = [np.zeros(6)]

def handle_calculate_IK(req):
    REQUESTS.append(len(req.poses))
    points = []
    for pose in req.poses:
        p, o = pose.position, pose.orientation
        T = pose_matrix([p.x, p.y, p.z], [o.x, o.y, o.z, o.w])
        PREV[0] = kinematics.committed().nearest(T, PREV[0])
        point = JointTrajectoryPoint()
        point.positions = list(PREV[0])
        points.append(point)
    return CalculateIKResponse(points)

def IK_server():
    rospy.init_node('IK_server')
    s = rospy.Service('calculate_ik', CalculateIK, handle_calculate_IK)
    rospy.spin()

if __name__ == "__main__":
    IK_server()
"""


def _requests(user: UserIk) -> list[int]:
    """The sizes of the requests the server got (its script's global)."""
    server = user.function.__self__  # the RosServer whose solve() this is
    return list(server.module.REQUESTS)


def test_ik_check_asks_in_batches(tmp_path: Path) -> None:
    path = tmp_path / "IK_server.py"
    path.write_text(SERVER)
    user = load_ik(str(path))
    result = run_check(user, n_random=100, progress=io.StringIO())
    assert result.passed
    n = result.report["summary"]["cases"]
    sizes = _requests(user)
    assert sizes == [BATCH] * (n // BATCH) + [n % BATCH]


def test_a_straight_line_is_one_request_and_judged_sample_by_sample(tmp_path: Path) -> None:
    path = tmp_path / "IK_server.py"
    path.write_text(SERVER)
    user = load_ik(str(path))
    runner = Runner(RunConfig(cycles=1, seed=0), ik=user)
    run_session(runner, io.StringIO())
    assert runner.results[0].success
    sizes = _requests(user)
    checked = runner.planner.user_ik
    assert checked is not None and sum(sizes) == checked.stats.calls
    singles = [s for s in sizes if s == 1]
    assert len(singles) == 2 and len(sizes) == 5  # standoff and drop poses; three lines


def test_prefetched_answers_are_taken_for_the_same_poses(tmp_path: Path) -> None:
    path = tmp_path / "IK_server.py"
    path.write_text(SERVER)
    user = load_ik(str(path))
    kin = kinematics.committed()
    guard = CheckedIk(user, kin)
    q0 = np.array([0.1, 0.3, -0.2, 0.0, 0.8, 0.0])
    T0 = kin.forward(q0)
    T1 = T0.copy()
    T1[2, 3] += 0.1
    poses = line_poses(T0, T1, 0.01)
    n = len(poses)
    assert n in (10, 11)  # 1 cm apart (ceil of 0.1 m / 0.01 m in floating point)
    guard.prefetch(poses)
    q = q0
    for T in poses:
        q = guard.solve(T, q, "lift line sample", max_step=0.1)
    assert _requests(user) == [n] and guard.stats.calls == n
    guard.solve(T1, q, "again")  # not prefetched: a request of its own
    assert _requests(user) == [n, 1]
    ours = call_many(load_ik("kr210_sim.robot.kinematics:nearest"), poses[:2], [q0, q0])
    assert len(ours) == 2 and all(np.asarray(a).shape == (6,) for a, _ in ours)
