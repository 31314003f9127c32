"""A class of original-form submissions (tests/ros_class.py: Python 2 ROS servers with tabs,
a class-based one, a pickle beside one, a slow sympy one, and the classic mistakes) graded in
one call, in the jail; and one IK written in both forms, graded alike."""

from __future__ import annotations

import io
import re
from pathlib import Path

import numpy as np
import pytest
import ros_class

import kr210_sim
from kr210_sim.robot import kinematics
from kr210_sim.sandbox.user_ik import load_ik


@pytest.mark.slow
def test_a_class_of_original_form_submissions_is_graded_in_one_call(tmp_path: Path) -> None:
    """Every verdict is about the student's code; each mistake named in the student's terms;
    the slow sympy server graded within --timeout on what fitted, and the report says so."""
    folder = ros_class.write_class(tmp_path / "class")
    before = {p: p.read_bytes() for p in folder.rglob("*") if p.is_file()}
    out = io.StringIO()
    report = kr210_sim.grade(
        folder,
        cases=100,
        cycles=1,
        timeout=40.0,
        workers=2,
        report=tmp_path / "grade.json",
        out=out,
    )
    by = {s["name"]: s for s in report.students}
    assert {n: s["verdict"] for n, s in by.items()} == ros_class.EXPECTED
    for name in ("alice", "bob", "carol", "oscar"):
        assert by[name]["detail"] == "ik-check 168/168 cases, run 1/1 cycles (pass bar 1)", name
    spec = by["alice"]["spec"]
    assert spec == f"{folder}/alice/kuka_arm/scripts/IK_server.py:handle_calculate_IK"

    dave = by["dave"]  # 0.08-0.5 s a pose (the machine's load): what fitted in its 40 s
    ik = dave["ik_check"]
    assert ik["passed"] == ik["cases"] >= 48 and ik["cases_total"] == 168
    assert dave["detail"].startswith(f"ik-check {ik['cases']}/{ik['cases']} cases")
    assert dave["wall_time_s"]["student"] <= 40.0

    def finding(name: str) -> dict[str, str]:
        return {f["code"]: f["text"] for f in by[name]["diagnosis"]}

    assert "IK_server.py line 113) on 168 of 168 poses" in finding("erin")["name_error"]
    assert "with the orientation of an earlier pose" in finding("frank")["stale_rotation"]
    assert "(yours is Rx(roll) Ry(pitch) Rz(yaw);" in finding("grace")["euler_order"]
    assert "54.0 mm from the pose" in finding("heidi")["offset_0054"]
    assert "`303/1000` divides integers" in finding("mallory")["python2"]
    assert "answers hold a complex number" in finding("ivan")["complex"]
    assert "has free symbols q1, q2, q3" in finding("judy")["unevaluated"]
    assert by["peggy"]["detail"].endswith(
        "IK_server.py line 4 imports moveit_commander, a ROS package kr210_sim does not provide "
        "(it provides rospy, tf, tf2_ros, kuka_arm.srv, geometry_msgs.msg, std_msgs.msg, "
        "trajectory_msgs.msg, sensor_msgs.msg, visualization_msgs.msg, roslib, and the .msg and "
        ".srv types of the repository's own catkin packages)"
    )
    assert by["trent"]["detail"].endswith(
        "IK_server.py line 51: `theta2 =` cannot be read as Python 2 (a syntax error at the "
        "end of the line)"
    )
    assert report.data["config"]["jail"] is True
    assert {p: p.read_bytes() for p in folder.rglob("*") if p.is_file()} == before


def test_one_ik_in_both_forms_gives_the_same_answers_and_verdicts(tmp_path: Path) -> None:
    """The same closed form as a ROS server (Python 2, tf's roll, pitch and yaw) and as
    solve(T, q_ref): the same answers to 1e-9 rad, the same verdicts and figures; only fewer
    branch changes for the server, whose angles are taken at their 2 pi twins nearest q_ref (it
    was never sent q_ref) where ours answered a turn away from it."""
    ros, ours = ros_class.cross_check()
    server = tmp_path / "class" / "as_ros" / "kuka_arm" / "scripts" / "IK_server.py"
    server.parent.mkdir(parents=True)
    server.write_text(ros)
    (tmp_path / "class" / "as_ours.py").write_text(ours)
    kin = kinematics.committed()
    q = np.random.default_rng(11).uniform(kin.geometry.lower, kin.geometry.upper, (200, 6))
    poses = [kin.forward(v) for v in q]
    theirs = load_ik(str(server)).batch
    assert theirs is not None
    mine = load_ik(f"{tmp_path}/class/as_ours.py:solve").function
    for T, v, a in zip(poses, q, theirs(poses), strict=True):
        b = mine(T, v)
        assert (a is None) == (b is None)
        if a is not None:
            np.testing.assert_allclose(a, b, atol=1e-9)
    report = kr210_sim.grade(tmp_path / "class", cases=20, cycles=2, workers=2, out=io.StringIO())
    a, b = (next(s for s in report.students if s["name"] == n) for n in ("as_ros", "as_ours"))
    assert a["verdict"] == b["verdict"] == "pass"
    assert a["detail"] == b["detail"]
    for key in ("cases", "passed", "outside_limits"):
        assert a["ik_check"][key] == b["ik_check"][key]
    assert a["ik_check"]["branch_changes"] < b["ik_check"]["branch_changes"]
    assert a["ik_check"]["max_position_error_m"] == pytest.approx(
        b["ik_check"]["max_position_error_m"], abs=1e-9
    )
    assert a["run"]["successes"] == b["run"]["successes"] == 2


#: A server that takes 50 ms a pose (sleeping, so the load of the machine hardly matters).
SLOW = ros_class.sleeping_server(0.05)


def test_a_slow_server_is_graded_on_what_fits_in_its_time(tmp_path: Path) -> None:
    """50 ms a pose and --timeout 8: the IK_debug and cell cases (48: 2.4 s), no cycle (110
    poses would take 5.5 s of the few left), and the other cases within a quarter of the
    budget; the verdict is about the answers tried, and says how many."""
    (tmp_path / "slow.py").write_text(SLOW)
    (record,) = kr210_sim.grade(
        tmp_path / "slow.py", cases=100, cycles=10, timeout=8.0, out=io.StringIO()
    ).students
    ik = record["ik_check"]
    assert record["verdict"] == "pass"
    assert 48 < ik["cases"] < ik["cases_total"] == 168 and ik["passed"] == ik["cases"]
    assert record["run"]["cycles_run"] == 0
    assert record["detail"] == (
        f"ik-check {ik['cases']}/{ik['cases']} cases (tried {ik['cases']} of 168 in --timeout "
        f"8 s), run not tried ({record['run']['not_tried']})"
    )
    why = record["run"]["not_tried"]
    assert re.match(
        r"a cycle asks for about 110 poses, \d+ s at 0\.0[5-9]\d* s a pose, and \d s", why
    )
    assert record["wall_time_s"]["student"] < 8.0
