"""The loop closed (``run --perceive``): real cycles picked from what the sensors saw on the
published and the cluttered cell, scored against the truth; a target not there is ``not_seen``;
the perceived outcomes; the bay read off the layout against the one read off the cell file."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from kr210_sim.cell.layout import CellLayout
from kr210_sim.cell.load import model_at
from kr210_sim.cell.toml import load_cell
from kr210_sim.errors import ConfigError, NotSeenError
from kr210_sim.perception.bays import bay_box
from kr210_sim.plan.cycle import Move
from kr210_sim.score.report import build_report, strip_wall
from kr210_sim.score.scoring import Outcome, perceived_outcome, plan_failure
from kr210_sim.sensors.perceiver import LOOK_PHASE, Perceiver
from kr210_sim.sim.perceived import grasp_tolerance, layout_bay
from kr210_sim.sim.runner import RunConfig, Runner
from kr210_sim.sim.targets import place_upright

CELLS = Path(__file__).resolve().parents[2] / "scenes" / "cells"
#: Largest position error of a perceived target accepted here [mm] (the pipeline's figures on
#: these cells: 1-4 mm from the fixed sensor's look).
ERROR_BOUND_MM = 6.0


@pytest.mark.parametrize("name", ["published", "cluttered", "grid_4x2"])
def test_the_bay_off_the_layout_is_the_bay_off_the_cell_file(name: str) -> None:
    """Two readings of every slot's bay (the compiled model's sites, the cell file's figures)
    agree to 1 um."""
    path = CELLS / f"{name}.toml"
    shelf, layout = load_cell(path).shelf, CellLayout.from_model(model_at(path))
    for slot in range(1, len(layout.slots) + 1):
        a, b = bay_box(shelf, slot), layout_bay(layout, slot)
        np.testing.assert_allclose(b.centre, a.centre, atol=1e-6)
        np.testing.assert_allclose(b.half, a.half, atol=1e-6)
        assert b.yaw == pytest.approx(a.yaw, abs=1e-9)
    with pytest.raises(ValueError, match=r"slot 99 is not on the shelf \(slots 1-"):
        layout_bay(layout, 99)


def test_perceived_outcomes() -> None:
    tol = grasp_tolerance(0.05)
    assert tol == pytest.approx(0.179 / 2 - 0.05)
    assert perceived_outcome(Outcome.SUCCESS, False, 0.1, tol) is Outcome.SUCCESS
    assert perceived_outcome(Outcome.GRASP_MISSED, False, 0.0, tol) is Outcome.WRONG_OBJECT
    assert perceived_outcome(Outcome.COLLISION, False, 0.0, tol) is Outcome.WRONG_OBJECT
    off = perceived_outcome(Outcome.GRASP_MISSED, True, tol + 0.001, tol)
    assert off is Outcome.GRASP_MISSED_ESTIMATE_OFF
    assert perceived_outcome(Outcome.GRASP_MISSED, True, tol - 0.001, tol) is Outcome.GRASP_MISSED
    assert perceived_outcome(Outcome.NOT_SEEN, False, 0.0, tol) is Outcome.NOT_SEEN
    assert plan_failure(NotSeenError("x")) is Outcome.NOT_SEEN


def test_perceive_needs_a_perceiver_and_without_it_the_report_is_unchanged() -> None:
    with pytest.raises(ConfigError, match=r"perceive=True\) needs a perceiver"):
        Runner(RunConfig(cycles=1, perceive=True))
    report = build_report(RunConfig(cycles=1), [], None)
    assert "perceive" not in report["config"] and "perception" not in report["summary"]


def test_two_perceived_cycles_on_the_cluttered_cell() -> None:
    """The pick list's two kinds (the blue target, then the red can) among clutter, each picked
    into the bin from what the sensors saw (the fixed sensor's look, and the wrist camera's,
    which measures the radius); the report carries what was seen."""
    runner = Runner(
        RunConfig(cycles=2, seed=0, perceive=True),
        model=model_at(CELLS / "cluttered.toml"),
        perceiver=Perceiver,
    )
    results = [runner.run_cycle(i, runner.slot_for_cycle()) for i in (1, 2)]
    for r, label in zip(results, ("target", "red_can"), strict=True):
        p = r.perception
        assert r.success, r.detail
        assert p is not None and p["label"] == label and p["label_seen"] == label
        assert p["seen"] and p["right_object"]
        assert 0.0 < p["position_error_mm"] < ERROR_BOUND_MM
        assert 0.0 <= p["axis_error_deg"] < 5.0
        assert p["looks"] in (1, 2) and len(p["clusters"]) == p["looks"]
        assert max(p["clusters"]) >= 2  # the target and a neighbour seen (by either look)
        assert p["cpu_time_ms"] > 0.0
    report = build_report(RunConfig(cycles=2, perceive=True), results, 1.0)
    assert report["config"]["perceive"] is True
    s = report["summary"]["perception"]
    assert (s["cycles"], s["recognised"], s["recognition_rate"]) == (2, 2, 1.0)
    errs = [r.perception["position_error_mm"] for r in results]  # type: ignore[index]
    assert s["position_error_mm"]["max"] == max(errs)
    assert s["position_error_mm"]["median"] == pytest.approx(np.median(errs))
    stripped = strip_wall(report)["cycles"][0]["perception"]
    assert "cpu_time_ms" not in stripped and "wall_look_ms" not in stripped
    assert stripped["position_error_mm"] == errs[0]


def test_a_perceived_cycle_on_the_published_cell() -> None:
    runner = Runner(RunConfig(cycles=1, seed=4, slot=5, perceive=True), perceiver=Perceiver)
    r = runner.run_cycle(1, 5)
    assert r.success, r.detail
    p = r.perception
    assert p is not None and p["seen"] and p["right_object"] and p["label_seen"] == "target"
    assert p["position_error_mm"] < ERROR_BOUND_MM


def test_a_target_not_there_is_not_seen() -> None:
    """The cycle's target taken off the shelf after it spawned: the fixed look sees an empty
    bay, the wrist camera is carried to the slot for a second look, and the cycle is
    ``not_seen`` before any pick (the arm back at ready)."""
    runner = Runner(RunConfig(cycles=1, seed=0, slot=2, perceive=True), perceiver=Perceiver)
    perceiver = runner.perceiver
    assert isinstance(perceiver, Perceiver)
    sample, k = runner.start_cycle(1, 2)
    place_upright(runner.cell, k, (0.0, -1.5, 0.2))  # on the floor, away from everything
    mujoco.mj_forward(runner.model, runner.cell.data)
    moves: list[str] = []

    def track(move: Move) -> None:
        moves.append(move.phase)
        runner.cell.track(move.trajectory, None, move.phase)

    with pytest.raises(NotSeenError, match=r"target not seen in slot 2: not seen \(clusters: "):
        perceiver.look(runner.cell, k, sample, "target", runner.q_cmd, track)
    rec = perceiver.record
    assert rec is not None and not rec.seen and rec.looks == 2 and moves == [LOOK_PHASE]
    assert rec.position_error_mm is None and perceiver.estimate is None
