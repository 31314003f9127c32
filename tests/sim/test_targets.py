"""The target pool: a fresh cylinder every cycle, and no cylinder leaves the bin unseen."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from kr210_sim.cell.layout import CellLayout
from kr210_sim.cell.load import load_model
from kr210_sim.cell.spec import TargetSpec
from kr210_sim.score.report import build_report
from kr210_sim.score.scoring import in_bin
from kr210_sim.sim.cell import Cell
from kr210_sim.sim.runner import RunConfig, Runner
from kr210_sim.sim.targets import TargetPool


@pytest.mark.slow
@pytest.mark.chaotic
def test_a_run_past_nine_cycles_empties_the_bin_as_an_event() -> None:
    """Slot 5 twelve times: after nine cycles a cylinder stands at each of the nine drop spots
    and none has room for the tenth (``plan.landing.spots_with_room``), so the bin is emptied
    before cycle 10, and no cylinder leaves the bin unseen."""
    runner = Runner(RunConfig(cycles=12, seed=2, slot=5))
    cell, n = runner.cell, len(runner.cell.handles.target_bodies)
    bin_spec = runner.layout.bin
    before: set[int] = set()
    for i in range(1, 13):
        r = runner.run_cycle(i, 5)
        assert r.success, r.detail
        now = {k for k in range(n) if in_bin(cell.target_pose(k)[0], bin_spec)}
        moved = {k for e in runner.events if e.before_cycle == i for k in e.targets}
        assert before - moved <= now, f"cycle {i}: cylinders left the bin unseen"
        before = now
    (event,) = runner.events
    assert event.kind == "bin_emptied" and event.before_cycle == 10
    assert sorted(event.targets) == list(range(9))
    assert event.detail == (
        "the bin was emptied (9 cylinders): no drop spot has room for another cylinder"
    )
    assert len(before) == 3  # cycles 10 to 12 in a freshly emptied bin
    report = build_report(runner.config, runner.results, None, events=runner.events)
    assert report["events"][0]["kind"] == "bin_emptied"


@pytest.mark.chaotic
def test_a_cycle_with_no_spare_cylinder_left_empties_the_bin_first() -> None:
    """All ten cylinders in play (standing on the floor beside the bin): the next cycle's
    spawn empties the bin and picks them up first, an event before that cycle."""
    runner = Runner(RunConfig(cycles=1))
    spec = runner.layout.target
    for k in range(10):
        runner.targets.spawn((1.0, 2.0 + 0.2 * k, 0.125), 0.0, spec)
    assert runner.targets.spare == []
    r = runner.run_cycle(1, 5)
    assert r.success, r.detail
    (event,) = runner.events
    assert (event.kind, event.before_cycle, event.targets) == ("bin_emptied", 1, tuple(range(10)))
    assert event.detail == (
        "the bin was emptied (0 cylinders) and 10 cylinders outside it were picked up"
    )
    assert runner.targets.in_play == [0]


def test_spawning_takes_spares_in_order_and_restocking_returns_them() -> None:
    cell = Cell(load_model())
    pool = TargetPool(cell, CellLayout.from_model(cell.model))
    got = [pool.spawn((2.6, 0.0, 1.8), 0.0, TargetSpec()) for _ in range(10)]
    assert got == list(range(10)) and pool.spare == []
    with pytest.raises(IndexError):
        pool.spawn((2.6, 0.0, 1.8), 0.0, TargetSpec())
    event = pool.restock(before_cycle=11)
    assert pool.spare == list(range(10)) and pool.in_play == []
    assert (
        event.detail
        == "the bin was emptied (0 cylinders) and 10 cylinders outside it were picked up"
    )
    park = CellLayout.from_model(cell.model).park[3]
    assert np.allclose(cell.target_pose(3)[0], park)


def test_a_cylinder_dropped_from_release_height_does_not_sink_into_the_bin_floor() -> None:
    """The bin floor's contact is as stiff as the targets': with MuJoCo's default (solref
    0.02 s) a cylinder released at 1.6 m sank 31-33 mm into it.

    A 2 ms step moves a 5.3 m/s cylinder 10.6 mm, so the first contact sample can already be
    that deep (discretisation no stiffness removes); what the contact must not do is give way
    after it: the depth never grows past the first sample by more than 2 mm, and the cylinder
    rests with under 0.5 mm of penetration."""
    model = load_model()
    floor = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "bin_floor")
    for spec in (TargetSpec(), TargetSpec(radius=0.06, length=0.3, mass=0.5)):
        cell = Cell(model)
        k = TargetPool(cell, CellLayout.from_model(cell.model)).spawn((0.0, 2.5, 1.6), 0.0, spec)
        g = int(cell.handles.target_geoms[k])
        depths: list[float] = []
        for _ in range(1000):
            mujoco.mj_step(model, cell.data)
            d = cell.data
            hit = [
                -d.contact[i].dist for i in range(d.ncon) if {*d.contact[i].geom[:]} == {floor, g}
            ]
            if hit:
                depths.append(max(hit))
        assert depths, "the cylinder never reached the bin floor"
        assert max(depths) - depths[0] <= 0.002
        assert max(depths) <= 0.0106  # at most one step of free fall
        assert depths[-1] < 0.0005
