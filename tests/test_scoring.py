"""Scoring on constructed situations: every failure reason and the success case."""

from __future__ import annotations

import numpy as np
import pytest

from kr210_sim.cell.layout import BinBox
from kr210_sim.score.scoring import (
    REST_SPEED,
    REST_SPIN,
    REST_WINDOW,
    CycleObservation,
    Outcome,
    in_bin,
    is_still,
    rest_window_ticks,
    score,
)

BIN = BinBox(center=(0.0, 2.5), inner_half=(0.44, 0.44), floor_top=0.05, rim=1.0)
IN_BIN = np.array([0.05, 2.5, 0.1])


def obs(**kw: object) -> CycleObservation:
    base: dict[str, object] = dict(
        planned=True,
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
        ({"planned": False, "grasp_confirmed": False}, Outcome.UNREACHABLE),
        ({"robot_env_contacts": 3}, Outcome.COLLISION),
        ({"grasp_confirmed": False, "target_toppled": True}, Outcome.KNOCKED_OVER),
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
        ({"target_speed": REST_SPEED * 5, "rested_for": 0.0}, Outcome.MISSED_BIN),  # moving
        ({"rested_for": REST_WINDOW - 0.002}, Outcome.MISSED_BIN),  # still, but not for long
    ],
)
def test_failure_reasons(changes: dict[str, object], expected: Outcome) -> None:
    assert score(obs(**changes), BIN) is expected


def test_precedence_unreachable_over_everything() -> None:
    o = obs(planned=False, robot_env_contacts=5, grasp_confirmed=False)
    assert score(o, BIN) is Outcome.UNREACHABLE


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
