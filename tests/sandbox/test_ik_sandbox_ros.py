"""A ROS-form server in the sandbox (sandbox/ik_sandbox.py's batches): one request for many poses,
a pose's exception its own answer, a time limit per pose, the files beside the script in its
working folder, the student's files untouched, and Python 2's notes brought back."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pytest
import ros_class

from kr210_sim.robot import kinematics
from kr210_sim.sandbox.guarded import load_user_ik
from kr210_sim.sandbox.ik_guard import assess
from kr210_sim.sandbox.ik_sandbox import IkSandbox, Limits, SandboxStop
from kr210_sim.sandbox.user_ik import load_ik

KIN = kinematics.committed()
Q = np.random.default_rng(5).uniform(KIN.geometry.lower / 2, KIN.geometry.upper / 2, (12, 6))
POSES = [kinematics.forward(q) for q in Q]


def _digests(folder: Path) -> dict[str, str]:
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if p.is_file()
    }


def test_a_ros_server_answers_batches_as_it_does_in_process(tmp_path: Path) -> None:
    repo = ros_class.write_class(tmp_path / "class", ("alice",)) / "alice"
    before = _digests(repo)
    with IkSandbox(str(repo), Limits(call_timeout=2.0), capture=True) as box:
        assert box.ros and box.user_ik().batch is not None
        answers = box.batch(POSES)
        assert box.calls == 1 and box.poses == len(POSES)
        assert all(assess(KIN, T, q, a).passed for T, q, a in zip(POSES, Q, answers, strict=True))
        single = box(POSES[0], Q[0])
        assert "Received 12 eef-poses from the plan" in box.stdout.text()
    here = load_ik(str(repo)).batch
    assert here is not None
    np.testing.assert_allclose(np.asarray(answers[0]), here(POSES[:1])[0], atol=1e-12)
    assert assess(KIN, POSES[0], Q[0], single).passed  # from where the last answer left
    assert _digests(repo) == before and not list(repo.rglob("__pycache__"))


def test_the_files_beside_the_script_are_read_from_its_working_folder(tmp_path: Path) -> None:
    """carol reads dh_params.pkl by a relative path at import, as under rosrun from the
    scripts folder; the scratch folder holds a copy."""
    repo = ros_class.write_class(tmp_path / "class", ("carol",)) / "carol"
    scratch = tmp_path / "scratch"
    with IkSandbox(str(repo), Limits(call_timeout=2.0), scratch=scratch, capture=True) as box:
        answers = box.batch(POSES[:3])
    assert all(
        assess(KIN, T, q, a).passed for T, q, a in zip(POSES[:3], Q[:3], answers, strict=True)
    )
    assert (scratch / "dh_params.pkl").read_bytes() == (
        repo / "kuka_arm" / "scripts" / "dh_params.pkl"
    ).read_bytes()


def test_exceptions_are_answers_and_python_2_notes_come_back(tmp_path: Path) -> None:
    folder = ros_class.write_class(tmp_path / "class", ("erin", "mallory"))
    with IkSandbox(str(folder / "erin"), Limits(call_timeout=2.0), capture=True) as box:
        answers = box.batch(POSES[:3])
    assert [type(a).__name__ for a in answers] == ["NameError"] * 3
    assert str(answers[0]).startswith("name 'q' is not defined (IK_server.py line ")
    with IkSandbox(str(folder / "mallory"), Limits(call_timeout=2.0), capture=True) as box:
        box.batch(POSES[:3])
        assert box.notes == [
            "IK_server.py line 16: `303/1000` divides integers (303 / 1000 = 0 under Python 2, "
            "as under ROS; 0.303 in true division): write 303.0 / 1000 if 0.303 is meant"
        ]


SLOW = """import rospy, time
from kuka_arm.srv import *
from trajectory_msgs.msg import JointTrajectoryPoint

def handle_calculate_IK(req):
    points = []
    for pose in req.poses:
        time.sleep(HANG if pose.position.z > 5 else 0.2)
        point = JointTrajectoryPoint()
        point.positions = [0.0] * 6
        points.append(point)
    return CalculateIKResponse(points)
HANG = 30
"""


def test_a_batch_may_take_the_time_limit_per_pose(tmp_path: Path) -> None:
    """Four poses at 0.2 s each pass a limit of 0.3 s per pose; a pose that hangs is a
    timeout, with stop=True the student's verdict."""
    path = tmp_path / "IK_server.py"
    path.write_text(SLOW)
    with IkSandbox(str(path), Limits(call_timeout=0.3), capture=True) as box:
        assert len(box.batch(POSES[:4])) == 4
    far = POSES[0].copy()
    far[2, 3] = 9.0
    with IkSandbox(str(path), Limits(call_timeout=0.3), capture=True, stop=True) as box:
        with pytest.raises(SandboxStop) as stop:
            box.batch([POSES[0], far])
    assert stop.value.verdict == "timeout" and "no answer within 0.6 s" in stop.value.detail


def test_run_and_ik_check_load_a_repository_into_a_process_of_its_own(tmp_path: Path) -> None:
    repo = ros_class.write_class(tmp_path / "class", ("bob",)) / "bob"
    user = load_user_ik(str(repo))
    assert user.spec == f"{repo}/kuka_arm/scripts/IK_server.py:handle_calculate_IK"
    assert isinstance(user.function, IkSandbox) and user.batch is not None
    assert load_user_ik(user.spec) is user
    assert all(isinstance(a, np.ndarray) for a in user.batch(POSES[:2]))


def test_run_takes_the_repository(tmp_path: Path, capfd: pytest.CaptureFixture[str]) -> None:
    """``run --ik REPO``: the server runs in a process of its own, and the report names the
    SPEC the repository resolved to."""
    import json

    from kr210_sim.cli import main

    repo = ros_class.write_class(tmp_path / "class", ("alice",)) / "alice"
    report = tmp_path / "run.json"
    assert main(["run", "--ik", str(repo), "--cycles", "1", "--report", str(report)]) == 0
    out = capfd.readouterr().out
    assert "PASS: 1/1" in out and "Received" in out  # the server's own log reaches the terminal
    ik = json.loads(report.read_text())["summary"]["ik"]
    assert ik["spec"] == f"{repo}/kuka_arm/scripts/IK_server.py:handle_calculate_IK"
