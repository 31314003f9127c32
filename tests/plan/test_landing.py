"""Where a dropped cylinder lands: the drop spots that reach the bin's floor."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from random_cells import random_cell

from kr210_sim.cell.handles import CellHandles
from kr210_sim.cell.layout import CellLayout
from kr210_sim.cell.load import compile_cell, model_for
from kr210_sim.cell.toml import PUBLISHED_CELL, parse_cell
from kr210_sim.plan.landing import (
    landing_blocker,
    landing_blockers,
    lying_top,
    pile_heights,
    spots_with_room,
    tumble_band,
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
    and four points on the rim, on the axes) all missed it, the rings do not. It also stands
    in the band behind drop spot 4 that a cylinder released there tumbles through."""
    model = compile_cell(parse_cell(_with_box((0.06, 2.56, 1.15), (0.06, 0.06, 0.1))))
    blockers = landing_blockers(model)
    assert blockers[0] == (
        "a cylinder dropped here lands on obstacle_1 at z = 1.20 m, above the bin's floor (0.05 m)"
    )
    assert blockers[3].startswith("a cylinder dropped here strikes obstacle_1 at z = 1.20 m")
    assert usable_drop_spots(blockers) == (1, 2, 4, 5, 6, 7, 8)


def test_a_beam_over_part_of_the_bin_stops_the_spots_below_it() -> None:
    """The red team's beam: 1.2 m across the bin's middle row, 10 cm above the rim. Spots 1-3
    are under it; 4-6, 0.12 m beyond it, are in reach of a tumbling cylinder (of 9 cycles
    there, the 3 in which the cylinder touched the palm tumbled onto the beam)."""
    model = compile_cell(parse_cell(_with_box((0.0, 2.5, 1.1), (1.2, 0.2, 0.1))))
    blockers = landing_blockers(model)
    assert usable_drop_spots(blockers) == (6, 7, 8)
    assert blockers[3] == (
        "a cylinder dropped here strikes obstacle_1 at z = 1.15 m, above the bin's rim, as it "
        "tumbles (up to 0.18 m back towards the robot)"
    )


def test_a_beam_behind_the_one_spot_left_stops_it_too() -> None:
    """A cell drawn at random (seed 5007 of ``tests/random_cells.py``): a beam over most of a
    narrow bin, 9 cm beyond the end of which drop spot 9 stood clear of the footprint's rays.
    Every cycle carried there and the cylinder, tumbling back onto the beam, was thrown a metre
    out of the bin (missed_bin, 3 of 3, while check served every slot)."""
    blockers = landing_blockers(compile_cell(parse_cell(random_cell(5007).text)))
    assert usable_drop_spots(blockers) == ()
    assert blockers[8] == (
        "a cylinder dropped here strikes obstacle_1 at z = 0.85 m, above the bin's rim, as it "
        "tumbles (up to 0.22 m back towards the robot)"
    )


def test_the_tumble_band_lies_behind_the_spot() -> None:
    """The published target: back to 5 cm of drift and the 0.135 m half-diagonal, 0.07 m to
    either side, rays 2 cm apart at most."""
    band = np.array(tumble_band(0.05, 0.25))
    assert band[:, 0].min() == pytest.approx(-0.05 - np.hypot(0.05, 0.125))
    assert band[:, 0].max() == 0.0 and np.abs(band[:, 1]).max() == pytest.approx(0.07)
    assert np.diff(np.unique(band[:, 0])).max() <= 0.02 + 1e-12


def _one_at_drop_spot_1(
    upright: bool,
) -> tuple[mujoco.MjModel, mujoco.MjData, CellLayout, CellHandles]:
    """The published cell with a cylinder at drop spot 1 on the bin's floor, standing or lying
    on its side (along y)."""
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
    return model, data, layout, h


@pytest.mark.parametrize(("upright", "height"), [(True, 0.30), (False, 0.15)])
def test_pile_heights_see_the_cylinders_in_the_bin(upright: bool, height: float) -> None:
    """A cylinder standing (lying) at drop spot 1: one dropped there lands 0.25 m (0.10 m)
    above the floor, on it, and so may one tumbling back from drop spot 4 (0.22 m beyond it);
    the other spots are free."""
    model, data, layout, h = _one_at_drop_spot_1(upright)
    z = np.maximum(*pile_heights(model, data, layout, h))  # under the spot, or behind it
    assert z[0] == pytest.approx(height, abs=1e-3) and z[3] == pytest.approx(height, abs=1e-3)
    assert np.allclose(np.delete(z, [0, 3]), 0.05, atol=1e-6)


def test_pile_heights_see_a_cylinder_standing_behind_the_spot() -> None:
    """A cylinder standing 0.14 m back of drop spot 1 (towards the robot), clear of the
    footprint's rays: a tumbling cylinder may come down on it (edge cell 6010 of
    ``tests/random_cells.py``: one landed upright on another, its centre above the low bin's
    rim, missed_bin). The spot's pile is that cylinder's top; one as far beyond the spot is not
    in the band."""
    model = model_for()
    data = mujoco.MjData(model)
    h = CellHandles.from_model(model)
    layout = CellLayout.from_model(model)
    a = int(h.target_qpos[3])
    x, y = layout.drop_spots[0]  # radial: +y
    for dy, height in ((-0.14, 0.30), (0.14, 0.05)):
        mujoco.mj_resetDataKeyframe(model, data, 0)
        data.qpos[a : a + 7] = (x, y + dy, 0.05 + 0.125, 1.0, 0.0, 0.0, 0.0)
        mujoco.mj_forward(model, data)
        z = np.maximum(*pile_heights(model, data, layout, h))  # under the spot, or behind it
        assert z[0] == pytest.approx(height, abs=1e-3)


@pytest.mark.parametrize(
    ("upright", "room"), [(True, (1, 2, 3, 4, 5, 6, 7, 8)), (False, tuple(range(9)))]
)
def test_a_cylinder_standing_at_a_spot_leaves_it_no_room_one_lying_there_does(
    upright: bool, room: tuple[int, ...]
) -> None:
    """A cylinder standing at drop spot 1 (its top 0.30 m) leaves that spot no room: one dropped
    on it may topple across its neighbours' tops (edge cell 9013, see ``plan.landing``). One
    lying there (its top 0.15 m, below the published cell's 0.155 m, :func:`lying_top`) does
    not. Drop spot 4, 0.22 m beyond spot 1, sees the standing one in the band behind it (not
    under its footprint), but a cylinder tumbling onto it keeps its centre (0.30 + 0.125 m)
    below the 1 m rim: room."""
    model, data, layout, h = _one_at_drop_spot_1(upright)
    assert lying_top(model, layout, h) == pytest.approx(0.155)
    under, behind = pile_heights(model, data, layout, h)
    top = 0.30 if upright else 0.15
    assert under[0] == pytest.approx(top, abs=1e-3) and under[3] == pytest.approx(0.05)
    assert behind[0] == pytest.approx(top, abs=1e-3) and behind[3] == pytest.approx(top, abs=1e-3)
    assert spots_with_room(model, data, layout, h, 0.25, range(9)) == room


def test_mujoco_gets_a_cylinder_lying_across_a_standing_ones_top_wrong() -> None:
    """Why no cylinder is dropped on a standing one (``plan.landing``): edge cell 9013's tenth
    cylinder, toppled off the first, lying 0.65 deg off level with its lower end across the top
    rim of the one standing at drop spot 6 (as placed there, relative to it: the standing one
    first in geom order, as the cell has them). MuJoCo 4.0.1's multi-point collision reports
    two contacts 94.8 mm deep along the lying one's axis; they overlap 2.7 mm
    (``mj_geomDistance``, and the contact without multi-point collision). In the cell that
    contact threw the cylinder up at 3.4 m/s and out of the bin. Should an upgrade of MuJoCo
    make this fail, the contact is fixed: see whether a standing cylinder can take another."""
    xml = """<mujoco><worldbody>
      <body><freejoint/><geom type="cylinder" size="0.05 0.125"/></body>
      <body pos="0.0362 -0.0713 0.1737" quat="-0.4352 0.0765 0.7070 0.5522">
        <freejoint/><geom type="cylinder" size="0.05 0.125"/></body>
    </worldbody></mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    lying = data.geom_xmat[1].reshape(3, 3)[:, 2]
    assert np.degrees(np.arcsin(abs(lying[2]))) == pytest.approx(0.65, abs=0.01)
    depths = [1e3 * data.contact[i].dist for i in range(data.ncon)]
    assert depths == pytest.approx([-94.8, -94.8], abs=0.1)
    assert abs(data.contact[0].frame[:3] @ lying) == pytest.approx(1.0, abs=1e-3)  # its axis
    assert 1e3 * mujoco.mj_geomDistance(model, data, 0, 1, 0.1, None) == pytest.approx(
        -2.7, abs=0.1
    )
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_MULTICCD
    mujoco.mj_forward(model, data)
    assert [1e3 * data.contact[i].dist for i in range(data.ncon)] == pytest.approx([-2.7], abs=0.1)
