"""Scoring on constructed situations: every failure reason, its detail, and the success case."""

from __future__ import annotations

import numpy as np
import pytest

from kr210_sim.cell.layout import BinBox
from kr210_sim.errors import IkFailedError, NoPathError, UnreachablePoseError
from kr210_sim.score.scoring import (
    REST_SPEED,
    REST_SPIN,
    REST_WINDOW,
    CycleObservation,
    Outcome,
    RestCounter,
    bin_region,
    contained,
    episode_success,
    in_bin,
    is_still,
    judge,
    outcome_decided,
    plan_failure,
    rest_window_ticks,
    rise,
    score,
)


def lifting(h: float, mass: float = 0.05) -> float:
    """Energy [J] that lifts a target of ``mass`` [kg] by ``h`` [m]."""
    return mass * 9.81 * h


BIN = BinBox(center=(0.0, 2.5), inner_half=(0.44, 0.44), floor_top=0.05, rim=1.0)
IN_BIN = np.array([0.05, 2.5, 0.1])


def obs(**kw: object) -> CycleObservation:
    base: dict[str, object] = dict(
        grasp_confirmed=True,
        held_until_release=True,
        released=True,
        robot_env_contacts=0,
        target_position=IN_BIN,
        target_speed=0.0,
        target_spin=0.0,
        rested_for=REST_WINDOW,
    )
    base.update(kw)
    return CycleObservation(**base)  # type: ignore[arg-type]


def test_success() -> None:
    assert score(obs(), BIN) is Outcome.SUCCESS


@pytest.mark.parametrize(
    ("changes", "expected"),
    [
        ({"plan_failure": Outcome.UNREACHABLE, "grasp_confirmed": False}, Outcome.UNREACHABLE),
        ({"plan_failure": Outcome.NO_PATH, "grasp_confirmed": False}, Outcome.NO_PATH),
        ({"plan_failure": Outcome.IK_FAILED}, Outcome.IK_FAILED),
        ({"robot_env_contacts": 3}, Outcome.COLLISION),
        ({"grasp_confirmed": False, "target_tilt_deg": 85.0}, Outcome.KNOCKED_OVER),
        ({"grasp_confirmed": False, "target_tilt_deg": 20.0}, Outcome.GRASP_MISSED),
        (
            {"grasp_confirmed": False, "target_position": np.array([2.6, 0, 0.914])},
            Outcome.GRASP_MISSED,
        ),
        (
            {"held_until_release": False, "target_position": np.array([1.0, 1.0, 0.05])},
            Outcome.DROPPED_IN_TRANSIT,
        ),
        ({"released": False}, Outcome.DROPPED_IN_TRANSIT),
        ({"target_position": np.array([0.7, 2.5, 0.05])}, Outcome.MISSED_BIN),
        ({"target_position": np.array([0.0, 2.5, 1.2])}, Outcome.MISSED_BIN),  # on the rim
        # centre inside, rolling on the floor: it cannot leave (0.1 m/s lifts it 0.5 mm)
        ({"rested_for": 0.0, "target_speed": 0.1, "energy": lifting(0.0005)}, Outcome.SUCCESS),
        # centre inside, but what moves in the bin could lift it over the rim (0.9 m up)
        ({"rested_for": 0.0, "energy": lifting(0.91)}, Outcome.NOT_SETTLED),
        ({"rested_for": 0.0, "energy": lifting(0.89)}, Outcome.SUCCESS),
        # the same energy lifts a lighter target higher
        ({"energy": lifting(0.89), "target_mass": 0.03}, Outcome.NOT_SETTLED),
        # never missed_bin with the centre inside, however it moves
        ({"rested_for": 0.0, "energy": 10.0, "target_speed": 20.0}, Outcome.NOT_SETTLED),
    ],
)
def test_failure_reasons(changes: dict[str, object], expected: Outcome) -> None:
    assert score(obs(**changes), BIN) is expected


def test_precedence_unreachable_over_everything() -> None:
    o = obs(plan_failure=Outcome.UNREACHABLE, robot_env_contacts=5, grasp_confirmed=False)
    assert score(o, BIN) is Outcome.UNREACHABLE


def test_plan_failures_by_error() -> None:
    assert plan_failure(IkFailedError("x")) is Outcome.IK_FAILED
    assert plan_failure(NoPathError("x")) is Outcome.NO_PATH
    assert plan_failure(UnreachablePoseError("x")) is Outcome.UNREACHABLE


def test_contained_is_the_energy_bound() -> None:
    centre, half = bin_region(BIN)
    z = IN_BIN[2]
    up = BIN.rim - z
    assert contained(IN_BIN, up - 1e-6, centre, half)
    assert not contained(IN_BIN, up + 1e-6, centre, half)
    assert not contained([0.7, 2.5, 0.3], 0.0, centre, half)  # outside the walls
    assert rise(lifting(0.2), 0.05) == pytest.approx(0.2)
    # vectorised over a batch
    batch = contained(np.array([IN_BIN, IN_BIN]), np.array([0.0, 1.0]), centre, half)
    assert batch.tolist() == [True, False]


def test_the_settle_wait_ends_when_the_outcome_is_decided() -> None:
    """Inside the bin for good: decided at once, moving or not. Elsewhere: decided once still for
    the rest window, counted tick by tick (one moving tick restarts the count)."""
    assert outcome_decided(IN_BIN, 0.0, lifting(0.001), 0.05, BIN)
    assert not outcome_decided(IN_BIN, 0.0, lifting(0.95), 0.05, BIN)  # could still leave
    floor = np.array([1.5, 1.0, 0.1])  # fell beside the bin
    rest = RestCounter(0.002)
    ticks = [rest.update(0.0, 0.0) for _ in range(rest.window)]
    assert ticks[-1] and not any(ticks[:-1]) and rest.rested_for == pytest.approx(REST_WINDOW)
    assert outcome_decided(floor, rest.rested_for, lifting(0.5), 0.05, BIN)
    assert not rest.update(REST_SPEED * 5, 0.0) and rest.rested_for == 0.0
    assert not outcome_decided(floor, rest.rested_for, 0.0, 0.05, BIN)
    rest.update(0.0, REST_SPIN * 2)  # turning fast with a still centre is moving too
    assert rest.rested_for == 0.0


@pytest.mark.parametrize(
    ("changes", "words"),
    [
        ({}, [""]),
        (
            {"plan_failure": Outcome.NO_PATH, "plan_message": "the carry move hits bin_wall"},
            ["the carry move hits bin_wall"],
        ),
        (
            {"robot_env_contacts": 7, "contact_pairs": (("link_6", "bin_wall_n"),)},
            ["7 ticks", "link_6/bin_wall_n"],
        ),
        (
            {
                "grasp_confirmed": False,
                "target_tilt_deg": 88.4,
                "grasp_attempts": 1,
                "finger_gap": 0.0712,
                "target_radius": 0.05,
                "slot": 5,
            },
            ["knocked over in slot 5", "(axis 88 deg", "finger gap 71.2 mm", "diameter 100.0 mm"],
        ),
        (
            {"grasp_confirmed": False, "grasp_attempts": 2, "finger_gap": 0.02},
            ["grip not confirmed on attempt 2", "finger gap 20.0 mm"],
        ),
        ({"held_until_release": False}, ["left the fingers", "[0.05, 2.5, 0.1]"]),
        (
            {"target_position": np.array([0.7, 2.5, 0.05])},
            ["ended outside the bin at [0.7, 2.5, 0.05]"],
        ),
        (
            {"energy": 0.5, "target_speed": 4.47, "target_spin": 1.5},
            ["inside the bin at [0.05, 2.5, 0.1]", "4.470 m/s and 1.50 rad/s", "500.0 mJ"],
        ),
    ],
)
def test_detail_says_what_was_measured(changes: dict[str, object], words: list[str]) -> None:
    outcome, detail = judge(obs(**changes), BIN)
    assert (detail == "") is (outcome is Outcome.SUCCESS)
    assert all(w in detail for w in words), detail


def test_a_centre_above_the_rim_inside_the_walls_is_said_so() -> None:
    """A cylinder standing on the floor of a bin shallower than half its length: missed_bin
    (the centre is not below the rim), and the detail no longer says it ended outside the
    bin."""
    outcome, detail = judge(obs(target_position=np.array([0.0, 2.5, 1.2])), BIN)
    assert outcome is Outcome.MISSED_BIN
    assert detail.startswith(
        "the target's centre ended above the bin's rim, inside its walls, at [0.0, 2.5, 1.2] "
        "(rim at z = 1.000 m; it counts only with its centre below the rim), moving at 0.000 m/s"
    )
    assert "outside" not in detail
    outside = judge(obs(target_position=np.array([0.7, 2.5, 1.2])), BIN)[1]
    assert outside.startswith("the target ended outside the bin at [0.7, 2.5, 1.2]")


def test_episode_success_is_the_cycle_rule() -> None:
    """The Gymnasium environment's success (vectorised) agrees with :func:`score` on the same
    facts, a robot-cell contact included."""
    centre, half = bin_region(BIN)
    cases = [
        {},
        {"robot_env_contacts": 1},
        {"released": False},
        {"energy": lifting(0.95)},
        {"target_position": np.array([0.7, 2.5, 0.05])},
        {"target_position": np.array([0.0, 2.5, 1.2])},
    ]
    observed = [obs(**c) for c in cases]
    batch = episode_success(
        np.array([o.target_position for o in observed]),
        rise([o.energy for o in observed], [o.target_mass for o in observed]),
        np.array([o.released for o in observed]),
        np.array([o.robot_env_contacts for o in observed]),
        centre,
        half,
    )
    assert batch.tolist() == [score(o, BIN) is Outcome.SUCCESS for o in observed]
    assert batch.tolist() == [True, False, False, False, False, False]


def test_in_bin_walls_and_rim() -> None:
    half = BIN.inner_half[0]
    cx, cy = BIN.center
    assert in_bin([cx, cy, 0.2], BIN)
    assert in_bin([cx + half - 1e-3, cy, 0.2], BIN)
    assert not in_bin([cx + half + 1e-3, cy, 0.2], BIN)
    assert not in_bin([cx, cy - half - 1e-3, 0.2], BIN)
    assert not in_bin([cx, cy, BIN.rim + 0.01], BIN)
    assert not in_bin([cx, cy, BIN.floor_top - 0.01], BIN)
    assert not in_bin([cx + half - 0.01, cy, 0.2], BIN, margin=0.02)


def test_still_needs_both_slow_centre_and_slow_spin() -> None:
    assert is_still(0.0, 0.0)
    assert not is_still(REST_SPEED * 1.01, 0.0)
    # A cylinder rocking on its rim: its centre barely moves, it turns at 0.37 rad/s (seen in
    # randomised episodes scored at rest by the old one-tick linear-speed test).
    assert not is_still(0.01, 0.37)
    assert not is_still(0.0, REST_SPIN * 1.01)


def test_rest_window_in_ticks() -> None:
    assert rest_window_ticks(0.002) == round(REST_WINDOW / 0.002)
    assert rest_window_ticks(10.0) == 1
