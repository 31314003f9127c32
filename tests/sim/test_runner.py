"""End-to-end cycles in the real cell, and every failure reason on constructed situations."""

from __future__ import annotations

import json
from typing import Any

import mujoco
import numpy as np
import pytest

from kr210_sim.cell.load import load_model
from kr210_sim.cell.spec import MotionConfig
from kr210_sim.score.report import build_report, strip_wall
from kr210_sim.score.scoring import in_bin
from kr210_sim.sim.cell import Cell
from kr210_sim.sim.runner import RunConfig, Runner


@pytest.mark.slow
def test_one_cycle_per_row_succeeds_with_small_creep_and_no_contact() -> None:
    runner = Runner(RunConfig(cycles=3, seed=1))
    m, d = runner.cell.model, runner.cell.data
    pads = [m.geom(f"{side}_finger_pad").id for side in ("left", "right")]
    carry = {"ticks": 0, "both_pads": 0}

    def hook(cell: Cell) -> None:
        """Count the carry's ticks in which both pads press on the held cylinder."""
        if cell.phase != "carry":
            return
        target = int(cell.handles.target_geoms[cell.active_target])
        touching = set()
        for g1, g2 in zip(d.contact.geom1[: d.ncon], d.contact.geom2[: d.ncon], strict=True):
            if target in (g1, g2):
                touching.add(int(g1 + g2 - target))
        carry["ticks"] += 1
        carry["both_pads"] += all(p in touching for p in pads)

    runner.cell.hooks.append(hook)
    for i, slot in enumerate((1, 5, 9), start=1):  # bottom, middle, top row
        carry.update(ticks=0, both_pads=0)
        r = runner.run_cycle(i, slot)
        # the lips never wedge the cylinder away from the pads (the 8 mm lips did on MuJoCo
        # 4.0.1: both pads touched it in 26-36 % of the carry's ticks, the creep 3.5-5.8 mm)
        assert carry["ticks"] > 300 and carry["both_pads"] == carry["ticks"], carry
        assert r.success, r.detail
        assert r.reason is None
        assert r.env_contact_ticks == 0
        assert r.creep_mm < 2.0
        assert max(r.max_tracking_error_deg) < 0.1  # inverse-dynamics feed-forward
        assert r.max_gripper_tracking_error_mm < 2.0
        assert r.cycle_time < 6.5
        assert r.grasp_attempts == 1
        assert in_bin(r.target_final, runner.layout.bin)
        # the cycle ran its plan's steps, to the next drop spot in turn
        assert runner.plan is not None and runner.plan.drop_spot == i - 1
        assert list(r.phase_times) == ["spawn", *runner.plan.phases, "settle"]
    # all three cylinders are in the bin, and each went to its own drop spot
    finals = np.array([r.target_final for r in runner.results])
    assert len({tuple(np.round(f[:2], 1)) for f in finals}) == 3


@pytest.mark.slow
@pytest.mark.chaotic
def test_the_main_job_succeeds_ten_times_and_empties_the_full_bin_once() -> None:
    runner = Runner(RunConfig())  # what `run --cycles 10` runs
    results = [runner.run_cycle(i, runner.slot_for_cycle()) for i in range(1, 11)]
    assert [r.success for r in results] == [True] * 10, [r.detail for r in results]
    assert {(r.slot - 1) // 3 for r in results} == {0, 1, 2}  # every row visited
    assert sum(r.env_contact_ticks for r in results) == 0
    assert max(r.cycle_time for r in results) < 6.0
    # Nine cylinders stand at the nine drop spots after nine cycles: no room for the tenth
    # (plan.landing.spots_with_room; it was dropped on the first before).
    (event,) = runner.events
    assert (event.kind.value, event.before_cycle, event.targets) == (
        "bin_emptied",
        10,
        tuple(range(9)),
    )
    # The last drop may still jostle what is in the bin: give it 2 s, then all ten rest, the
    # tenth inside the bin.
    runner.idle(2.0)
    cell = runner.cell
    resting = [cell.target_pose(k)[0] for k in range(len(cell.handles.target_bodies))]
    assert [k for k, p in enumerate(resting) if in_bin(p, runner.layout.bin)] == [9]
    assert max(cell.target_speed(k) for k in range(10)) < 0.01


def _one(config: RunConfig, slot: int = 5, model: mujoco.MjModel | None = None):  # type: ignore[no-untyped-def]
    runner = Runner(config, model=model)
    return runner, runner.run_cycle(1, slot)


def _site(model: mujoco.MjModel, name: str) -> int:
    return int(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, name))


def test_unreachable_target_is_scored_and_the_run_goes_on() -> None:
    model = load_model()
    model.site_pos[_site(model, "slot_5")] = (4.5, 0.0, 1.556)  # beyond reach: falls there
    runner, r = _one(RunConfig(cycles=2), model=model)
    assert not r.success and r.reason == "unreachable"
    assert "out of reach" in r.detail
    r2 = runner.run_cycle(2, 1)
    assert r2.success


@pytest.mark.chaotic
def test_a_cylinder_left_on_the_shelf_is_cleared_before_the_next_cycle_only() -> None:
    """A shelf out of reach: each cycle leaves its cylinder in its slot. It is taken off the
    shelf before the next cycle (an event), and not after the last: a 2-cycle run listed an
    event ``before_cycle`` 3."""
    from kr210_sim.cell.load import model_for
    from kr210_sim.cell.toml import PUBLISHED_CELL

    runner = Runner(
        RunConfig(cycles=2), model=model_for(cell=PUBLISHED_CELL.parent / "unreachable.toml")
    )
    for i in (1, 2):
        assert runner.run_cycle(i, 5).reason == "unreachable"
    assert [(e.kind.value, e.before_cycle) for e in runner.events] == [("shelf_cleared", 2)]


@pytest.mark.chaotic
def test_a_tower_at_a_drop_spot_leaves_it_no_room_and_the_bin_is_emptied_for_it() -> None:
    """Cylinders standing on each other at drop spot 1 (from two on: one alone in play is the
    one to pick): it has no room (``plan.landing.spots_with_room``), nor drop 4 with four (one
    tumbling back onto the tower from there, ``plan.landing.tumble_band``, would stand its
    centre above the rim). When the only spots the carry reaches have no room (drop 2, free,
    moved out of reach), the bin is emptied (an event, the cylinder to pick left in its slot)
    and the cycle planned again; it dropped onto the tower before."""
    model = load_model()
    model.site_pos[_site(model, "drop_2")] = (4.5, 2.5, 1.0)
    runner = Runner(RunConfig(cycles=1), model=model)
    x, y = runner.layout.drop_spots[0]
    spec = runner.layout.target
    for level in range(4):
        runner.targets.spawn((x, y, 0.05 + spec.length * (level + 0.5)), 0.0, spec)
        room = runner.drop_spots_with_room(spec.length)
        if level == 0:  # the one cylinder in play is taken to be the one to pick
            assert room == tuple(range(9))
        else:
            assert room == tuple(s for s in range(1, 9) if level < 3 or s != 3)
    runner.drop_spots = (0, 1)  # as if the carry reached drops 1 and 2 alone
    r = runner.run_cycle(1, 5)
    assert r.success, r.detail
    (event,) = runner.events
    assert (event.kind.value, event.before_cycle) == ("bin_emptied", 1)
    assert event.detail == (
        "the bin was emptied (4 cylinders): no drop spot with room for another cylinder could "
        "be reached"
    )
    assert runner.plan is not None and runner.plan.drop_spot == 0
    assert runner.targets.in_play == [4] and r.cycle_time < 6.0  # the event is not the arm's


@pytest.mark.chaotic
def test_a_bin_with_a_cylinder_standing_at_every_drop_spot_is_emptied_first() -> None:
    """Nine cylinders standing at the nine drop spots (the published bin after nine cycles): no
    spot has room, since one dropped on a standing cylinder may topple across its neighbours'
    tops and be thrown out of the bin (edge cell 9013's tenth cycle, ``plan.landing``); one
    lying on its side at drop 5 leaves it room. Then the bin is emptied before the cycle plans,
    and the cylinder goes to drop 1. It was dropped on the first of the nine before."""
    runner = Runner(RunConfig(cycles=1), model=load_model())
    spec = runner.layout.target
    for x, y in runner.layout.drop_spots:
        runner.targets.spawn((x, y, 0.05 + spec.length / 2.0), 0.0, spec)
    assert runner.drop_spots_with_room(spec.length) == ()
    x, y = runner.layout.drop_spots[4]
    runner.cell.data.qpos[runner.cell.handles.target_qpos[4] + np.arange(7)] = (
        x,
        y,
        0.05 + spec.radius,
        np.sqrt(0.5),
        np.sqrt(0.5),
        0.0,
        0.0,
    )
    mujoco.mj_forward(runner.model, runner.cell.data)
    assert runner.drop_spots_with_room(spec.length) == (4,)
    runner.targets._place(4, (x, y, 0.05 + spec.length / 2.0))  # standing again
    mujoco.mj_forward(runner.model, runner.cell.data)
    r = runner.run_cycle(1, 5)
    assert r.success, r.detail
    (event,) = runner.events
    assert (event.kind.value, event.before_cycle, event.targets) == (
        "bin_emptied",
        1,
        tuple(range(9)),
    )
    assert event.detail == (
        "the bin was emptied (9 cylinders): no drop spot has room for another cylinder"
    )
    assert runner.plan is not None and runner.plan.drop_spot == 0
    assert runner.targets.in_play == [9] and in_bin(r.target_final, runner.layout.bin)


def test_slippery_heavy_target_is_dropped_in_transit() -> None:
    model = load_model()  # the nominal target is target_0 as the model holds it
    model.geom_friction[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "target_0"), 0] = 0.02
    model.body_mass[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "target_0")] = 0.5
    _, r = _one(RunConfig(cycles=1), model=model)
    assert r.reason == "dropped_in_transit", r.detail


def test_release_outside_the_bin_misses_it() -> None:
    model = load_model()  # the drop spots are the model's sites drop_1 ...
    model.site_pos[_site(model, "drop_1")] = (0.9, 2.5, 1.0)
    _, r = _one(RunConfig(cycles=1), model=model)
    assert r.reason == "missed_bin", r.detail
    assert "outside the bin" in r.detail


def test_carrying_through_the_bin_wall_is_a_collision() -> None:
    motion = MotionConfig(drop_height=0.85)
    runner = Runner(RunConfig(cycles=1, motion=motion))
    runner.planner.checker = None  # the contact monitor, not the planner, must see it
    r = runner.run_cycle(1, 5)
    assert r.reason == "collision", r.detail
    assert r.env_contact_ticks > 0
    assert any("bin" in a or "bin" in b for a, b in r.contact_pairs)


def test_a_plan_into_the_bin_wall_is_no_path_before_the_arm_moves() -> None:
    motion = MotionConfig(drop_height=0.85)
    runner = Runner(RunConfig(cycles=1, motion=motion))
    r = runner.run_cycle(1, 5)
    assert r.reason == "no_path", r.detail
    assert "bin_wall" in r.detail and "carry move" in r.detail
    assert r.grasp_attempts == 1 and "approach" not in r.phase_times  # the arm never moved
    assert r.env_contact_ticks == 0


def test_wrong_size_belief_misses_the_grasp() -> None:
    class Narrow(Runner):
        """Plans for a 0.05 m radius, but the cylinder in the cell is 0.03 m."""

        def _spawn(self, sample):  # type: ignore[no-untyped-def]
            k = super()._spawn(sample)
            g = int(self.cell.handles.target_geoms[k])
            self.model.geom_size[g, 0] = 0.03
            return k

    runner = Narrow(RunConfig(cycles=1, grasp_attempts=2))
    r = runner.run_cycle(1, 5)
    assert r.reason == "grasp_missed"
    assert r.grasp_attempts == 2
    assert "grip not confirmed" in r.detail


def test_same_seed_same_report() -> None:
    reports = []
    for _ in range(2):
        runner = Runner(RunConfig(cycles=2, seed=7))
        for i in range(1, 3):
            runner.run_cycle(i, runner.slot_for_cycle())
        reports.append(
            json.dumps(strip_wall(build_report(runner.config, runner.results, 1.0)), sort_keys=True)
        )
    assert reports[0] == reports[1]


class _Misperceived(Runner):
    """The first observation of the target is off by ``offset`` [m]; later ones are exact."""

    offset = np.zeros(3)
    observations = 0

    def observe_target(self, index: int) -> np.ndarray:
        self.observations += 1
        position = super().observe_target(index)
        return position + (self.offset if self.observations == 1 else 0.0)


def test_missed_grasp_is_retried_from_a_fresh_observation_and_recovers() -> None:
    runner = _Misperceived(RunConfig(cycles=1))
    runner.offset = np.array([0.0, 0.0, 0.2])  # fingers close 0.2 m above the cylinder's centre
    r = runner.run_cycle(1, 5)
    assert r.success, r.detail
    assert r.grasp_attempts == 2 and runner.observations == 2
    assert r.env_contact_ticks == 0
    summary = build_report(runner.config, runner.results, 1.0)["summary"]
    assert summary["grasp_retries"] == 1


def test_a_target_knocked_over_in_its_slot_is_reported() -> None:
    runner = _Misperceived(RunConfig(cycles=2))
    # A finger sweeps into the cylinder's side. (At -0.06 m, since the 18 mm lips seat the
    # cylinder 11 mm deeper, MuJoCo 4.0.1 has the finger push it aside upright: regrasped.)
    runner.offset = np.array([0.0, -0.055, 0.0])
    r = runner.run_cycle(1, 5)
    assert r.reason == "knocked_over"
    assert "knocked over in slot 5" in r.detail
    assert r.grasp_attempts == 1  # no blind retry on a cylinder lying down
    # The toppled cylinder was cleared from the shelf: the next cycle runs normally.
    assert runner.run_cycle(2, 5).success


@pytest.mark.slow
@pytest.mark.chaotic
def test_cylinders_dropped_on_a_full_bin(monkeypatch: pytest.MonkeyPatch) -> None:
    """Nine cylinders in the bin, the tenth dropped on the pile (on the first of the nine, as
    runs did before a standing cylinder left its spot no room: the test lifts that rule for it):
    a success as soon as it cannot leave (the kinetic energy of every cylinder in play, all
    given to it, could not lift it to the rim), not after waiting for the pile to stop moving.
    Then the eleventh cycle (the bin emptied, a fresh pile of one) with a cylinder of the pile
    kicked up at 6 m/s as the wait begins and a wait too short for it to come down: inside the
    bin but not settled, and the detail says what was measured."""
    from kr210_sim.score.scoring import GRAVITY, REST_WINDOW
    from kr210_sim.sim import runner as runner_module

    runner = Runner(RunConfig(cycles=12, seed=3))
    for i in range(1, 10):
        assert runner.run_cycle(i, runner.slot_for_cycle()).success
    assert runner.targets.in_bin_count() == 9
    # nine stand here, one may have tumbled on another CPU: drop onto the pile regardless
    monkeypatch.setattr(runner, "drop_spots_with_room", lambda length: runner.drop_spots)
    r = runner.run_cycle(10, runner.slot_for_cycle())
    assert runner.plan is not None and runner.plan.drop_spot == 0 and not runner.events
    assert r.success and r.reason is None and r.detail == ""
    assert runner.targets.in_bin_count() == 10
    assert r.phase_times["settle"] < REST_WINDOW  # decided before any pile could have rested
    cell, bin_box = runner.cell, runner.layout.bin
    assert in_bin(r.target_final, bin_box)
    energy = sum(cell.target_energy(k) for k in runner.targets.in_play)
    mass = r.target.spec.mass
    assert r.target_final[2] + energy / (mass * GRAVITY) < bin_box.rim

    assert runner.run_cycle(11, runner.slot_for_cycle()).success  # the bin was emptied first
    kicked = runner.targets.in_play[0]
    hold = runner._hold

    def kick_then_hold(seconds: float, rec: Any, phase: str, *args: Any, **kw: Any) -> float:
        if phase == "settle":
            dof = int(cell.handles.target_dof[kicked])
            cell.data.qvel[dof : dof + 3] = (0.0, 0.0, 6.0)
        return hold(seconds, rec, phase, *args, **kw)

    monkeypatch.setattr(runner, "_hold", kick_then_hold)
    monkeypatch.setattr(runner_module, "SETTLE_TIMEOUT", 0.1)
    r = runner.run_cycle(12, runner.slot_for_cycle())
    assert r.reason == "not_settled" and in_bin(r.target_final, bin_box)
    assert "inside the bin" in r.detail and "mJ, enough to lift it" in r.detail, r.detail
    assert r.phase_times["settle"] == pytest.approx(0.1)
