"""``run --perceive --randomize`` on the cluttered cell, rendered: a target whose drawn radius is
far from the kind's 50 mm is looked at again with the wrist camera, which measures its radius,
and the pick is planned at a centre within 2 mm of the truth (the fixed look alone, taking the
kind's radius, was 8-13 mm off on these seeds). The truth only scores."""

from __future__ import annotations

from pathlib import Path

import pytest

from kr210_sim.cell.load import model_at
from kr210_sim.plan.cycle import Move
from kr210_sim.sensors.perceiver import LOOK_PHASE, Perceiver
from kr210_sim.sim.runner import RunConfig, Runner

CELL = Path(__file__).resolve().parents[2] / "scenes" / "cells" / "cluttered.toml"


@pytest.mark.parametrize("seed", [0, 5, 6])  # radii 56.3, 41.1, 59.7 mm drawn
def test_a_drawn_radius_is_measured_by_the_wrist_look(seed: int) -> None:
    runner = Runner(
        RunConfig(cycles=1, seed=seed, randomize=True, perceive=True),
        model=model_at(CELL),
        perceiver=Perceiver,
    )
    perceiver = runner.perceiver
    assert isinstance(perceiver, Perceiver)
    slot = runner.slot_for_cycle()
    sample, k = runner.start_cycle(1, slot)
    assert abs(sample.spec.radius - 0.05) > 0.006  # what the test is about
    moves: list[str] = []

    def track(move: Move) -> None:
        moves.append(move.phase)
        runner.cell.track(move.trajectory, None, move.phase)

    planned = perceiver.look(runner.cell, k, sample, "target", runner.q_cmd, track)
    rec = perceiver.record
    assert rec is not None and rec.seen and rec.right_object
    assert moves == [LOOK_PHASE] and rec.looks == 2
    assert perceiver.percept is not None
    far = [d for d in perceiver.percept.looks[0].detections if d.label == "target"]
    assert far and not any(d.measured for d in far)  # why the wrist look was taken
    assert planned.radius == pytest.approx(sample.spec.radius, abs=0.001)
    assert rec.position_error_mm is not None and rec.position_error_mm < 2.0
