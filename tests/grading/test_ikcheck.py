"""ik-check: the cases, the grading of our IK, the worked example and the classic mistake."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from kr210_sim.cell.layout import CellLayout
from kr210_sim.cell.load import load_model, model_for
from kr210_sim.cell.spec import MotionConfig
from kr210_sim.cli import main
from kr210_sim.grading.ikcheck import cell_cases, fixed_cases, random_cases, run_check
from kr210_sim.plan.planner import Planner
from kr210_sim.plan.poses import grasp_depth
from kr210_sim.robot import kinematics
from kr210_sim.robot.description import load_robot
from kr210_sim.sandbox.user_ik import UserIk, load_ik

KIN = kinematics.committed()

WORKED = f"{Path(__file__).resolve().parents[2] / 'examples' / 'ik_dh.py'}:solve"


def test_the_fixed_cases() -> None:
    cases = fixed_cases(KIN)
    groups = [c.group for c in cases]
    assert groups[:3] == ["ik_debug"] * 3  # the original script's cases come first
    assert groups.count("cell") == 9 * 4 + 9  # four poses per slot, nine drop spots
    assert (groups.count("zero"), groups.count("singular"), groups.count("limits")) == (1, 7, 12)
    assert len({c.name for c in cases}) == len(cases)
    (zero,) = (c for c in cases if c.group == "zero")
    np.testing.assert_allclose(zero.T[:3, 3], (2.153, 0.0, 1.946), atol=1e-12)
    g = KIN.geometry
    for c in cases:
        q = kinematics.nearest(c.T, c.q_ref)  # every case is reachable inside the limits
        assert np.all(q >= g.lower - 1e-9) and np.all(q <= g.upper + 1e-9)
    grasp = next(c for c in cases if c.name == "slot 5 grasp")
    depth = grasp_depth(load_robot(), 0.05)  # the cylinder's axis in the gripper frame
    assert 0.15 < depth < 0.25
    np.testing.assert_allclose(grasp.T[:3, 0], (1.0, 0.0, 0.0), atol=1e-12)  # towards +x
    assert grasp.T[0, 3] == pytest.approx(2.6 - depth)  # fingers around slot 5
    assert grasp.T[2, 3] == pytest.approx(1.556 + 0.125)
    lims = [c for c in cases if c.group == "limits"]
    assert max(np.abs(np.minimum(c.q_ref - g.lower, g.upper - c.q_ref)).min() for c in lims) == (
        pytest.approx(1e-3)
    )


def test_the_cell_cases_are_the_cycle_plans_poses() -> None:
    layout = CellLayout.from_model(load_model())
    planner = Planner(load_robot(), MotionConfig())
    t = layout.target
    p = layout.slots[4] + np.array([0.0, 0.0, t.length / 2.0])
    plan = planner.plan_cycle(planner.ready_q, p, t, layout.drop_spots)
    posed = [s for s in plan.steps if s.T is not None and s.pose != "drop"]
    cases = [c for c in cell_cases(KIN) if c.name.startswith("slot 5 ")]
    names = ["slot 5 standoff", "slot 5 grasp", "slot 5 lift", "slot 5 retreat"]
    assert [c.name for c in cases] == [f"slot 5 {s.pose}" for s in posed] == names
    for case, step in zip(cases, posed, strict=True):
        assert step.move is not None
        assert np.array_equal(case.T, step.T)
        assert np.array_equal(case.q_ref, step.move.trajectory.q_start)


def test_random_cases_are_seeded() -> None:
    a, b, c = (random_cases(KIN, 5, s) for s in (1, 1, 2))
    np.testing.assert_array_equal(a[3].T, b[3].T)
    assert not np.allclose(a[3].T, c[3].T)


def test_our_ik_passes_every_case() -> None:
    result = run_check(load_ik("kr210_sim.robot.kinematics:nearest"), n_random=300, seed=1)
    s = result.report["summary"]
    assert result.passed and s["cases"] == 68 + 300 and s["pass_rate"] == 1.0
    assert s["max_position_error_m"] < 1e-9 and s["max_orientation_error_rad"] < 1e-8
    assert s["branch_changes"] == 0
    assert result.text.splitlines()[-1] == (
        "PASS: 368/368 cases within 1 mm and 1 mrad, inside the joint limits"
    )


def test_the_worked_example_passes_every_case(tmp_path: Path) -> None:
    report = tmp_path / "ik.json"
    code = main(["ik-check", "--ik", WORKED, "--cases", "300", "--report", str(report)])
    assert code == 0
    data = json.loads(report.read_text())
    s = data["summary"]
    assert s["passed"] == s["cases"] == 368
    assert s["max_position_error_m"] < 1e-9 and s["max_orientation_error_rad"] < 1e-8
    assert s["branch_changes"] == 0 and s["raised"] == 0
    assert set(s["groups"]) == {"ik_debug", "cell", "zero", "singular", "limits", "random"}
    rec = data["cases"][0]
    for key in ("position_error_m", "orientation_error_rad", "within_limits", "passed", "error"):
        assert key in rec
    assert data["config"]["ik"] == WORKED


def test_the_missing_offset_fails_every_case_by_54_mm(
    no_offset_ik: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    report, plots = tmp_path / "ik.json", tmp_path / "plots"
    argv = ["ik-check", "--ik", no_offset_ik, "--cases", "200", "--report", str(report)]
    assert main([*argv, "--plots", str(plots)]) == 1
    out = capsys.readouterr().out
    assert "FAIL: 0/268 cases" in out and "worst cases (268 failed)" in out
    data = json.loads(report.read_text())
    answered = [r for r in data["cases"] if r["q"] is not None]
    assert len(answered) > 240  # a few poses near the edge of reach get None
    # The forearm is modelled 0.054 m off: the wrist centre (and the gripper) land 54 mm from
    # the pose, whatever the pose; the wrist still sets the orientation exactly.
    for r in answered:
        assert r["position_error_m"] == pytest.approx(0.054, abs=1e-6)
        assert r["wrist_centre_error_m"] == pytest.approx(0.054, abs=1e-6)
        assert r["orientation_error_rad"] < 1e-9
        assert "misses the pose by 54 mm" in r["problem"]
    assert all(r["problem"] == "returned None (unreachable)" for r in data["cases"] if not r["q"])
    assert sorted(p.name for p in plots.iterdir()) == [
        "ik_error_histograms.png",
        "ik_error_workspace.png",
    ]
    import matplotlib.image

    img = matplotlib.image.imread(plots / "ik_error_histograms.png")
    assert img.shape[0] > 300 and img[..., :3].std() > 0.05


def test_a_raising_function_is_recorded_with_its_message() -> None:
    calls = 0

    def picky(T: np.ndarray, q_ref: np.ndarray) -> np.ndarray:
        nonlocal calls
        calls += 1
        if T[2, 3] < 1.0:
            raise ValueError(f"too low: z = {T[2, 3]:.2f}")
        return kinematics.nearest(T, q_ref)

    result = run_check(UserIk("test:picky", picky), n_random=50, seed=0)
    s = result.report["summary"]
    low = [r for r in result.report["cases"] if r["position"][2] < 1.0]
    assert calls == s["cases"] == 118 and s["raised"] == len(low) > 0
    assert s["passed"] == s["cases"] - len(low)
    for r in low:
        assert r["error"].startswith("ValueError: too low: z = ")
        assert r["q"] is None and r["position_error_m"] is None and not r["passed"]
    assert "raised ValueError: too low" in result.text
    json.dumps(result.report, allow_nan=False)  # no NaN in the report


def test_answers_far_from_q_ref_are_flagged_not_failed() -> None:
    def first_branch(T: np.ndarray, q_ref: np.ndarray) -> np.ndarray:
        return kinematics.inverse(T)[0]  # ignores q_ref

    result = run_check(UserIk("test:first", first_branch), n_random=100, seed=0)
    s = result.report["summary"]
    assert result.passed
    assert s["branch_changes"] > 20
    kinds = {r["branch_change"] for r in result.report["cases"]} - {None}
    assert kinds <= {"wrist flip", "arm branch change", "2pi jump", "q4/q6 split"}
    assert "wrist flip" in kinds and "not the solution nearest q_ref" in result.text


@pytest.mark.parametrize(
    ("source", "message"),
    [
        (None, "no such file"),
        ("def solve(T, q)\n", "syntax error"),
        ("raise ImportError('sympy is too slow')\n", "raised ImportError: sympy is too slow"),
        ("def solver(T, q):\n    pass\n", "has no function 'solve' (it defines: solver)"),
        ("solve = [1, 2]\n", "is a list, not a function"),
    ],
)
def test_a_bad_spec_is_one_line_and_exit_2_before_anything_runs(
    tmp_path: Path, source: str | None, message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "bad.py"
    if source is not None:
        path.write_text(source)
    report = tmp_path / "ik.json"
    for argv in (
        ["ik-check", "--ik", f"{path}:solve", "--report", str(report)],
        ["run", "--ik", f"{path}:solve", "--report", str(report)],
    ):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert err.startswith("kr210_sim: error: --ik ") and message in err, err
        assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
        assert not report.exists()


def test_cases_must_be_a_count(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["ik-check", "--ik", WORKED, "--cases", "-1"])
    assert exc.value.code == 2 and "must be >= 0" in capsys.readouterr().err


def test_fixed_cases_only(tmp_path: Path) -> None:
    result = run_check(load_ik(WORKED), n_random=0, report_path=tmp_path / "r.json")
    assert result.report["summary"]["cases"] == 68
    assert math.isfinite(result.report["summary"]["wall_time_s"]["per_call_max"])
    assert json.loads((tmp_path / "r.json").read_text())["summary"]["cases"] == 68


def test_an_absurd_number_of_cases_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["ik-check", "--ik", "kr210_sim.robot.kinematics:nearest", "--cases", "1000000000"]
    assert main([*argv, "--report", str(tmp_path / "r.json")]) == 2
    err = capsys.readouterr().err
    assert (
        err
        == "kr210_sim: error: cases must be a whole number from 0 to 1,000,000, got 1000000000\n"
    )


def test_the_cell_cases_start_from_the_cells_ready_pose(ready_cell: Path) -> None:
    """A cell that sets ``[robot] ready_q``: every drop-spot case starts from it (it took the
    motion settings' default), and so does every slot's approach."""
    kin = kinematics.Kinematics(load_robot())
    cases = cell_cases(kin, model_for(cell=ready_cell))
    ready = np.radians([40, -15, 20, 0, -5, 0])
    drops = [c for c in cases if c.name.startswith("drop spot")]
    standoffs = [c for c in cases if c.name.endswith("standoff")]
    assert len(drops) == 9 and len(standoffs) == 9
    assert all(np.allclose(c.q_ref, ready) for c in (*drops, *standoffs))


def test_the_ik_debug_cases_and_what_the_script_printed(tmp_path: Path) -> None:
    """The three cases of the exercise's IK_debug.py: their wrist centres are the ones the script
    listed, Gazebo's angles are within 0.01 rad of our solution, and the report's rows give the
    script's figures, for the worked example and for the classic 0.054 m mistake."""
    from kr210_sim.grading.ik_debug import IK_DEBUG_CASES
    from kr210_sim.grading.ikcheck import ik_debug_cases

    cases = ik_debug_cases(KIN)
    assert [c.name for c in cases] == [f"IK_debug case {i}" for i in (1, 2, 3)]
    g = KIN.geometry
    listed = [(1.89451, -1.44302, 1.69366), (-0.638, 0.64198, 2.9988), (-1.1669, -0.17989, 0.85137)]
    for case, wc, (_, _, gazebo) in zip(cases, listed, IK_DEBUG_CASES, strict=True):
        np.testing.assert_allclose(case.T[:3, 3] - g.dg * case.T[:3, 0], wc, atol=7e-5)  # rounded
        ours = kinematics.nearest(case.T, case.q_ref)
        assert np.abs(ours - np.array(gazebo)).max() < 0.006  # given to 0.01 rad
    worked = run_check(load_ik(WORKED), n_random=0, report_path=tmp_path / "w.json")
    rows = worked.report["ik_debug"]
    assert [r["case"] for r in rows] == [1, 2, 3]
    for r in rows:
        assert r["end_effector_error_m"]["overall"] < 1e-9
        assert r["wrist_centre_error_m"]["overall"] < 1e-9
        assert 0.0005 < max(r["theta_errors_rad"]) < 0.006
    lines = worked.text.splitlines()
    head = lines.index(
        "  IK_debug.py's cases (theta errors against Gazebo's joint angles, given to 0.01 rad):"
    )
    first = lines[head + 3].split()
    assert first[:5] == ["1", "0.0000", "0.0000", "0.0000", "0.0000"]
    assert [float(v) for v in first[5:11]] == pytest.approx(rows[0]["theta_errors_rad"], abs=6e-5)
    # The 0.054 m drop left out: the angles put the wrist centre (and so the end effector)
    # 54 mm from where the pose puts it.
    spec = tmp_path / "no_drop.py"
    spec.write_text(
        Path(WORKED.rpartition(":")[0]).read_text().replace("\nA3 = -0.054", "\nA3 = 0.0")
    )
    wrong = run_check(load_ik(f"{spec}:solve"), n_random=0)
    for r in wrong.report["ik_debug"]:
        assert r["wrist_centre_error_m"]["overall"] == pytest.approx(0.054, abs=1e-9)
        assert r["end_effector_error_m"]["overall"] == pytest.approx(0.054, abs=1e-9)
        assert r["problem"].startswith("returned q")


def test_a_signal_stops_the_check_and_keeps_the_cases_tried(tmp_path: Path) -> None:
    """Ctrl-C twice, 2 ms apart, in the middle of a check: the report of the cases tried is
    written whole, marked interrupted, and the exit code is Ctrl-C's."""
    import os
    import signal
    import subprocess
    import sys
    import time

    slow = tmp_path / "slow.py"
    marker = tmp_path / "ten_calls"
    slow.write_text(
        "import time, pathlib\nfrom kr210_sim.robot.kinematics import nearest\n"
        f"N = [0]\nM = pathlib.Path({str(marker)!r})\n"
        "def solve(T, q):\n"
        "    N[0] += 1\n"
        "    if N[0] == 10:\n"
        "        M.write_text('')\n"
        "    time.sleep(0.01)\n"
        "    return nearest(T, q)\n"
    )
    report = tmp_path / "check.json"
    command = [sys.executable, "-m", "kr210_sim", "ik-check", "--ik", f"{slow}:solve"]
    proc = subprocess.Popen(
        [*command, "--cases", "2000", "--report", str(report)],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    end = time.monotonic() + 60
    while not marker.exists() and time.monotonic() < end and proc.poll() is None:
        time.sleep(0.02)
    proc.send_signal(signal.SIGINT)
    time.sleep(0.002)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "Traceback" not in err
    data = json.loads(report.read_text())
    tried = data["summary"]["cases"]
    assert data["interrupted"] == "SIGINT" and data["cases_planned"] == 68 + 2000
    assert 9 <= tried == len(data["cases"]) < 2068  # the tenth call's answer may be cut
    assert data["summary"]["passed"] == tried  # nearest answers every case tried
    assert f"  interrupted (SIGINT) after {tried} of 2068 cases" in out
    assert f"INTERRUPTED: {tried}/{tried} cases" in out
    left = sorted(p for p in os.listdir(tmp_path) if p != "__pycache__")  # slow.py's bytecode
    assert left == ["check.json", "slow.py", "ten_calls"]  # no temporary file left
