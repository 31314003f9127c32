"""``run --ik``: cycles planned with a user's IK, end to end (cli -> job -> runner -> task)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from kr210_sim.cli import main
from kr210_sim.robot import kinematics
from kr210_sim.sandbox.user_ik import UserIk
from kr210_sim.score.report import build_report, strip_wall
from kr210_sim.score.scoring import in_bin
from kr210_sim.sim.runner import RunConfig, Runner

WORKED = f"{Path(__file__).resolve().parents[2] / 'examples' / 'ik_dh.py'}:solve"


@pytest.mark.slow
def test_the_worked_example_runs_ten_of_ten(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    report = tmp_path / "run.json"
    assert main(["run", "--ik", WORKED, "--cycles", "10", "--report", str(report)]) == 0
    out = capsys.readouterr().out
    assert "PASS: 10/10" in out and f"IK {WORKED}: " in out
    data = json.loads(report.read_text())
    s = data["summary"]
    assert s["successes"] == 10 and s["env_contact_ticks"] == 0
    ik = s["ik"]
    # standoff + drop per cycle, and one call per 1 cm sample of the straight lines
    assert ik["spec"] == WORKED and ik["calls"] > 10 * 100
    t = ik["wall_time_s"]
    assert 0 < t["per_call_mean"] <= t["per_call_max"]
    branches = ik["branches"]  # the worked example answers the nearest solution, as ours
    assert branches["answered"] == 20 and branches["other_branch"] == 0
    assert strip_wall(s)["ik"] == {"spec": WORKED, "calls": ik["calls"], "branches": branches}


def test_the_missing_offset_fails_every_cycle_as_ik_failed(
    no_offset_ik: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    report = tmp_path / "run.json"
    assert main(["run", "--ik", no_offset_ik, "--cycles", "10", "--report", str(report)]) == 1
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err and "FAIL: 0/10" in captured.out
    data = json.loads(report.read_text())
    assert data["summary"]["failures"] == {"ik_failed": 10}
    assert data["summary"]["ik"]["calls"] == 10  # each cycle stops at its first pose
    for c in data["cycles"]:
        assert c["reason"] == "ik_failed"
        assert c["detail"].startswith("standoff pose [")
        assert "misses the pose by 54 mm" in c["detail"] and "allowed 1 mm, 1 mrad" in c["detail"]


def test_a_failure_after_the_grasp_releases_the_target_and_the_run_goes_on() -> None:
    calls = {"drop": 0}

    def fails_first_drop(T: np.ndarray, q_ref: np.ndarray) -> np.ndarray:
        if T[1, 3] > 1.5:  # the drop pose above the bin
            calls["drop"] += 1
            if calls["drop"] == 1:
                raise RuntimeError("cannot reach the bin today")
        return kinematics.nearest(T, q_ref)

    runner = Runner(RunConfig(cycles=2), ik=UserIk("test:fails_first_drop", fails_first_drop))
    r1 = runner.run_cycle(1, 5)
    assert r1.reason == "ik_failed" and r1.grasp_attempts == 1
    assert r1.detail.startswith("drop pose [")
    assert "test:fails_first_drop raised RuntimeError: cannot reach the bin today" in r1.detail
    assert not in_bin(r1.target_final, runner.layout.bin)
    assert runner.cell.grip_ctrl == runner.model.actuator_ctrlrange[runner.cell.handles.grip_act, 0]
    r2 = runner.run_cycle(2, 5)
    assert r2.success, r2.detail
    report = build_report(runner.config, runner.results, 1.0)
    assert report["summary"]["failures"] == {"ik_failed": 1}


def test_an_answer_that_raises_on_float_is_that_cycles_ik_failed() -> None:
    class NeedsGrad:  # a tensor that needs grad raises RuntimeError on float()
        def __float__(self) -> float:
            raise RuntimeError("needs grad")

    def tensor_ik(T: np.ndarray, q_ref: np.ndarray) -> list[NeedsGrad]:
        return [NeedsGrad()] * 6

    runner = Runner(RunConfig(cycles=1), ik=UserIk("test:tensor_ik", tensor_ik))
    r = runner.run_cycle(1, 5)
    assert r.reason == "ik_failed"
    assert "returned list, not six numbers (RuntimeError: needs grad)" in r.detail
