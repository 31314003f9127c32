"""Where a dropped cylinder lands: the drop spots that reach the bin's floor."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from kr210_sim.cell.handles import CellHandles
from kr210_sim.cell.layout import CellLayout
from kr210_sim.cell.load import compile_cell, model_for
from kr210_sim.cell.toml import PUBLISHED_CELL, parse_cell
from kr210_sim.plan.landing import (
    drop_heights,
    landing_blocker,
    landing_blockers,
    usable_drop_spots,
)
from kr210_sim.util.paths import SCENE_PATH


def _with_box(position: tuple[float, float, float], size: tuple[float, float, float]) -> str:
    box = f"\n[[obstacles]]\nposition = {list(position)}\nsize = {list(size)}\n"
    return PUBLISHED_CELL.read_text() + box


def test_every_drop_spot_of_the_published_cell_reaches_the_floor() -> None:
    blockers = landing_blockers(model_for())
    assert blockers == ("",) * 9
    assert usable_drop_spots(blockers) == tuple(range(9))


def test_a_crate_in_the_bin_stops_every_cylinder() -> None:
    """A scene with a crate in the bin passed `check` (every cycle then ended missed_bin)."""
    spec = mujoco.MjSpec.from_file(str(SCENE_PATH))
    crate = spec.worldbody.add_body(name="crate", pos=[0.0, 2.5, 0.4])
    crate.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.3, 0.3, 0.3])
    blocked = spec.compile()
    for n in range(1, 10):
        why = landing_blocker(blocked, CellLayout.from_model(blocked), n)
        assert why.startswith("a cylinder dropped here lands on crate at z = 0.70 m"), why


def test_a_box_over_a_corner_of_the_footprint_stops_it() -> None:
    """A 6 cm box above the rim whose corner reaches 42 mm from drop spot 1's centre (inside
    the 50 mm cylinder's footprint, on the diagonal): the five rays the check cast (the centre
    and four points on the rim, on the axes) all missed it, the rings do not."""
    model = compile_cell(parse_cell(_with_box((0.06, 2.56, 1.15), (0.06, 0.06, 0.1))))
    blockers = landing_blockers(model)
    assert blockers[0] == (
        "a cylinder dropped here lands on obstacle_1 at z = 1.20 m, above the bin's floor (0.05 m)"
    )
    assert usable_drop_spots(blockers) == (1, 2, 3, 4, 5, 6, 7, 8)


def test_a_beam_over_part_of_the_bin_stops_the_spots_below_it() -> None:
    """The red team's beam: 1.2 m across the bin's middle row, 10 cm above the rim."""
    model = compile_cell(parse_cell(_with_box((0.0, 2.5, 1.1), (1.2, 0.2, 0.1))))
    assert usable_drop_spots(landing_blockers(model)) == (3, 4, 5, 6, 7, 8)


@pytest.mark.parametrize(("upright", "height"), [(True, 0.30), (False, 0.15)])
def test_drop_heights_see_the_cylinders_in_the_bin(upright: bool, height: float) -> None:
    """A cylinder standing (lying) at drop spot 1: one dropped there lands 0.25 m (0.10 m)
    above the floor, on it; the other spots are free."""
    model = model_for()
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    h = CellHandles.from_model(model)
    layout = CellLayout.from_model(model)
    a = int(h.target_qpos[3])
    x, y = layout.drop_spots[0]
    if upright:
        data.qpos[a : a + 7] = (x, y, 0.05 + 0.125, 1.0, 0.0, 0.0, 0.0)
    else:  # on its side, along y
        data.qpos[a : a + 7] = (x, y, 0.05 + 0.05, np.sqrt(0.5), np.sqrt(0.5), 0.0, 0.0)
    mujoco.mj_forward(model, data)
    z = drop_heights(model, data, layout, h)
    assert z[0] == pytest.approx(height, abs=1e-3)
    assert np.allclose(z[1:], 0.05, atol=1e-6)
