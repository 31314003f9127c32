"""The typed cell config: published figures and validation."""

from __future__ import annotations

import numpy as np
import pytest

from kr210_sim.cell.spec import (
    CellConfig,
    MotionConfig,
    RandomizationSpec,
    TargetSpec,
)
from kr210_sim.cell.toml import published_cell
from kr210_sim.errors import ConfigError


def test_published_slots_sit_on_their_boards() -> None:
    cell = published_cell()
    for number in range(1, 10):
        p = cell.slot(number)
        row = (number - 1) // 3
        assert p[0] == pytest.approx(2.6)
        assert p[1] == pytest.approx((0.9, 0.0, -0.9)[(number - 1) % 3])
        # centre = board top + half the cylinder: no slot sinks into its board
        assert p[2] - cell.target.length / 2 == pytest.approx(cell.shelf.board_tops[row], abs=1e-9)


def test_published_figures() -> None:
    cell = published_cell()
    assert cell.shelf.board_tops == (0.789, 1.556, 2.322)
    assert cell.shelf.half_width == 1.4
    assert cell.bin.inner_half == (0.44, 0.44)
    assert cell.bin.drop_offsets()[:4] == [(0.0, 0.0), (0.22, 0.0), (-0.22, 0.0), (0.0, 0.22)]


@pytest.mark.parametrize("bad", [0, 10, -1])
def test_slot_out_of_range(bad: int) -> None:
    with pytest.raises(ConfigError, match="slot must be 1-9"):
        published_cell().slot(bad)


@pytest.mark.parametrize(
    "factory",
    [
        lambda: TargetSpec(radius=0.0),
        lambda: TargetSpec(mass=float("nan")),
        lambda: MotionConfig(lin_speed=0.0),
        lambda: RandomizationSpec(mass=(0.5, 0.02)),
        lambda: RandomizationSpec(xy_offset=-0.01),
        lambda: CellConfig("x", published_cell().shelf, published_cell().bin, n_targets=0),
    ],
)
def test_invalid_values_raise(factory: object) -> None:
    with pytest.raises(ConfigError):
        factory()  # type: ignore[operator]


def test_park_positions_are_distinct_and_on_floor() -> None:
    cell = published_cell()
    parks = np.array([cell.park_position(k) for k in range(cell.n_targets)])
    assert len({tuple(p) for p in parks.round(6)}) == cell.n_targets
    assert np.allclose(parks[:, 2], cell.target.length / 2)
