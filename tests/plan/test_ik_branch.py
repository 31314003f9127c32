"""Why cycles with a user's IK can be longer: its answers on another branch than the built-in
IK's, noted with the time they add, in the report and on the console (issue 42 item 3: a
ROS-form server that always answers the same wrist made cycles 5.6 s against 4.5 s)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from ros_class import numpy_server

from kr210_sim.cli import main
from kr210_sim.plan.ik_branch import BranchLog, BranchNote
from kr210_sim.plan.planner import Planner
from kr210_sim.plan.poses import untwisted_nearest
from kr210_sim.robot.description import load_robot
from kr210_sim.sim.runner import RunConfig

#: The same wrist every time (theta5 >= 0, no 2 pi twins, the first solution found): correct
#: answers that ignore where the arm is, as many original servers were written.
FIXED_WRIST = (
    numpy_server()
    .replace(
        "            for k4 in xrange(-2, 3):\n                for k6 in xrange(-2, 3):",
        "            for k4 in xrange(0, 1):\n                for k6 in xrange(0, 1):",
    )
    .replace(
        "                    if best is None or d < best[0]:",
        "                    if best is None:",
    )
)


def _flip(q: np.ndarray) -> np.ndarray:
    """The other wrist of the same pose: q4 + pi, -q5, q6 + pi."""
    out = q.copy()
    out[3] += np.pi if out[3] < 0 else -np.pi
    out[4] = -out[4]
    out[5] += np.pi if out[5] < 0 else -np.pi
    return out


def test_an_answer_on_the_other_wrist_is_noted_with_the_time_it_adds() -> None:
    planner = Planner(load_robot(), RunConfig().motion)
    kin = planner.kinematics
    q_ref = np.radians([10.0, -5.0, 5.0, 0.0, 20.0, 0.0])
    T = planner.drop_pose(np.array([0.0, 2.5]), 0.05)
    ours = untwisted_nearest(kin, T, q_ref)
    log = planner.ik_branches
    assert log.see(T, q_ref, ours + 1e-9, "drop", True, planner) is not None
    assert log.notes == []  # the same branch: nothing to say
    flipped = _flip(ours)
    np.testing.assert_allclose(kin.forward(flipped), kin.forward(ours), atol=1e-9)
    assert log.see(T, q_ref, flipped, "drop", True, planner) is flipped  # the user's answer
    (note,) = log.notes
    assert note.pose == "drop" and note.kind == "wrist flip"
    assert abs(abs(note.difference_deg[3]) - 180.0) < 0.1
    assert note.extra_s > 0.2  # half a turn of joint 4 (and 6) in and out
    summary = log.summary(cycles=1, ros_form=True)
    assert summary["answered"] == 2 and summary["other_branch"] == 1
    assert summary["by_pose"]["drop"]["kinds"] == {"wrist flip": 1}
    assert "sent no joint state" in summary["note"]
    assert f"at least {summary['extra_s_per_cycle']:.2f} s longer a cycle" in summary["note"]


def _run(tmp_path: Path, name: str, source: str) -> tuple[dict, str]:
    script = tmp_path / name / "kuka_arm" / "scripts" / "IK_server.py"
    script.parent.mkdir(parents=True)
    script.write_text(source)
    report = tmp_path / f"{name}.json"
    argv = ["run", "--ik", str(tmp_path / name), "--cycles", "2", "--report", str(report)]
    assert main(argv) == 0
    return json.loads(report.read_text()), name


@pytest.mark.slow
def test_a_ros_server_answering_one_wrist_is_told_why_its_cycles_are_longer(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    nearest, _ = _run(tmp_path, "nearest", numpy_server())  # keeps its last answer
    capsys.readouterr()
    fixed, _ = _run(tmp_path, "fixed", FIXED_WRIST)
    printed = capsys.readouterr().out
    quiet = nearest["summary"]["ik"]["branches"]
    assert quiet["other_branch"] == 0 and quiet["answered"] >= 4
    loud = fixed["summary"]["ik"]["branches"]
    assert loud["other_branch"] >= 2
    assert loud["by_pose"]["drop"]["kinds"] == {"wrist flip": 2}
    assert "IK branches: " in printed and "wrist flip" in printed
    # The note's lower bound is real and explains most of the longer cycles.
    t_near = np.mean([c["cycle_time"] for c in nearest["cycles"]])
    t_fixed = np.mean([c["cycle_time"] for c in fixed["cycles"]])
    assert t_fixed - t_near >= loud["extra_s_per_cycle"] > 0.5, (t_near, t_fixed, loud)


def test_a_branch_that_saves_time_is_not_called_slower() -> None:
    note = BranchNote("standoff", "wrist flip", (0.0, 0.0, 0.0, -180.0, 10.0, 180.0), -0.05)
    summary = BranchLog(answered=2, notes=[note]).summary(cycles=1, ros_form=False)
    assert summary["extra_s"] == -0.05 and "take no longer (-0.05 s)" in summary["note"]
    assert "slower" not in summary["note"]
