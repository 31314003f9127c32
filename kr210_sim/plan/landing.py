"""Where a dropped cylinder lands: which of a cell's drop spots reach the bin's floor.

A cylinder released above a drop spot falls straight down into the bin. When a part of the cell
stands in its way above the floor (a beam over the bin, a box in it), it lands on that instead
and the cycle ends ``missed_bin``, however well it was carried. :func:`landing_blockers` says
so for every drop spot, from rays cast straight down against the cell's colliders over the
cylinder's whole footprint and a margin round it; :func:`usable_drop_spots` keeps the others.

A released cylinder does not always fall straight: as the fingers open it often drifts back
towards the robot into the gripper's palm and tumbles end over end in the drop spot's radial
plane (the published cell: the centre 5 cm back, the ends up to 0.186 m back of the spot and
0.10 m beyond it above the rim, 0.06 m to the sides). What stands above the rim in the band
it tumbles through behind the spot (:func:`tumble_band`) is struck on the way down: a beam
there threw a cylinder a metre out of a narrow bin. So the rays also cover that band, and a
hit above the rim blocks the spot too.
The runner sends cylinders only to usable spots (:class:`~kr210_sim.sim.runner.Runner`),
``check`` refuses the rest, and ``run`` refuses a cell with none.

As the bin fills, a spot has room for another cylinder only where it comes down on the floor or
on cylinders lying on their sides (:func:`spots_with_room`), not on one standing upright. A
cylinder dropped on a standing one lands on its top and balances there only while that stands
plumb: in edge cell 9013 of ``tests/random_cells.py`` the tenth landed on the first, which the
eighth, tumbling, had knocked 4 deg off the vertical and 11 mm off the spot; it toppled and
came to lie almost level (0.65 deg) across the top of another standing one. That is a contact
MuJoCo 4.0.1's multi-point cylinder collision gets wrong: it reported the two overlapping
94.8 mm along the lying one's axis where they overlapped 2.7 mm (``mj_geomDistance``; the same
pair without multi-point collision, or in the other geom order, gives the 2.7 mm), and the
stiff contact threw the cylinder up at 3.4 m/s and out over the wall (missed_bin in a cycle
``check`` served). A pile no higher than a cylinder on its side keeps a toppling one well below
its neighbours' tops.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from kr210_sim.cell.handles import CellHandles
from kr210_sim.cell.layout import CellLayout

import mujoco  # isort: skip

FloatArray = npt.NDArray[np.float64]

#: Clearance kept round a falling cylinder's rim [m]: what stands within it stops the cylinder
#: or tips it over the wall (it sways as the fingers open).
LANDING_MARGIN = 0.02
#: The rays' rings round the drop spot, as (rays, radius over the cylinder's radius, margins):
#: half the radius, the rim, the rim plus :data:`LANDING_MARGIN` (and one ray at the centre);
#: neighbouring rays are about 2 cm apart for a 0.05 m cylinder.
RINGS = ((8, 0.5, 0), (16, 1.0, 0), (24, 1.0, 1))
#: How far a released cylinder's centre drifts back towards the robot as it tumbles [m]
#: (measured: 4-6 cm in the published cell).
TUMBLE_DRIFT = 0.05
#: Spacing of the rays over the tumble's band [m].
TUMBLE_STEP = 0.02
#: How far the pile under a drop spot may stand above a cylinder lying on its side on the bin's
#: floor and still count as one [m] (resting contacts settle within a millimetre or two).
PILE_TOLERANCE = 0.005
#: The geom groups rays are cast against: all but the drawn meshes' (group 2, which collide
#: with nothing and cost the rays four fifths of their time); they stop at whatever a falling
#: cylinder would collide with.
_GROUPS = np.array([1, 1, 0, 1, 1, 1], dtype=np.uint8)


def _footprint(radius: float) -> list[tuple[float, float]]:
    """Ray offsets [m] from a drop spot: its centre and the rings of :data:`RINGS`."""
    points = [(0.0, 0.0)]
    for n, scale, margins in RINGS:
        r = scale * radius + margins * LANDING_MARGIN
        angles = 2.0 * math.pi * np.arange(n) / n
        points += [(r * math.cos(a), r * math.sin(a)) for a in angles]
    return points


def tumble_band(radius: float, length: float) -> list[tuple[float, float]]:
    """Ray offsets (u, v) [m] over the band a tumbling cylinder sweeps behind its drop spot, in
    the spot's radial frame (u outwards from the joint_1 axis, v to its left): u from 0 back to
    :data:`TUMBLE_DRIFT` plus the reach of an end round the centre (the half-diagonal of the
    cylinder's section), v across the footprint and :data:`LANDING_MARGIN`; about
    :data:`TUMBLE_STEP` apart. The published target: u to -0.185 m, v within +-0.07 m."""
    back = TUMBLE_DRIFT + math.hypot(radius, length / 2.0)
    side = radius + LANDING_MARGIN
    us = np.linspace(-back, 0.0, max(2, math.ceil(back / TUMBLE_STEP) + 1))
    vs = np.linspace(-side, side, max(2, math.ceil(2 * side / TUMBLE_STEP) + 1))
    return [(float(u), float(v)) for u in us for v in vs]


def landing_blockers(
    model: mujoco.MjModel, layout: CellLayout | None = None, handles: CellHandles | None = None
) -> tuple[str, ...]:
    """What stops a cylinder dropped at each drop spot above the bin's floor, in the cell's
    order: "" when it falls to the floor, else a sentence naming the part and the height.

    Args:
        model: The cell model; the rays are cast at its first keyframe against every geom a
            target collides with (the robot's are passed through: the arm is above the
            cylinder when it lets go; so are the targets, parked away).
        layout: Its layout (default: read from ``model``).
        handles: Its handles (default: looked up in ``model``).
    """
    layout = layout or CellLayout.from_model(model)
    h = handles or CellHandles.from_model(model)
    data = mujoco.MjData(model)
    if model.nkey:
        mujoco.mj_resetDataKeyframe(model, data, 0)
    mujoco.mj_forward(model, data)
    floor, rim = layout.bin.floor_top, layout.bin.rim
    stops = _stops(model, h, targets=False)
    tumbles = _tumbles(model, data, layout, stops)
    out = []
    for (z, geom), (zt, gt) in zip(_landings(model, data, layout, stops), tumbles, strict=True):
        blocker = ""
        if geom >= 0 and z > floor + 0.005:
            blocker = (
                f"a cylinder dropped here lands on {_part(model, geom)} at z = {z:.2f} m, above "
                f"the bin's floor ({floor:.2f} m)"
            )
        elif gt >= 0 and zt > rim + 0.005:
            t = layout.target
            back = TUMBLE_DRIFT + math.hypot(t.radius, t.length / 2.0)
            blocker = (
                f"a cylinder dropped here strikes {_part(model, gt)} at z = {zt:.2f} m, above "
                f"the bin's rim, as it tumbles (up to {back:.2f} m back towards the robot)"
            )
        out.append(blocker)
    return tuple(out)


def _part(model: mujoco.MjModel, geom: int) -> str:
    """The name of ``geom``, else its body's."""
    name = model.geom(geom).name or model.body(int(model.geom_bodyid[geom])).name
    return name or "a geom"


def _tumbles(
    model: mujoco.MjModel, data: mujoco.MjData, layout: CellLayout, stops: frozenset[int]
) -> list[tuple[float, int]]:
    """Per drop spot, the highest first hit [m] of the rays over :func:`tumble_band` among
    ``stops``, and its geom (-1 when no ray meets any)."""
    top = layout.bin.rim + 1.0
    down = np.array([0.0, 0.0, -1.0])
    hit = np.zeros(1, dtype=np.int32)
    band = tumble_band(layout.target.radius, layout.target.length)
    out = []
    for x, y in layout.drop_spots[:, :2]:
        a = math.atan2(y, x)
        c, s = math.cos(a), math.sin(a)
        best = (-math.inf, -1)
        for u, v in band:
            start = np.array([x + u * c - v * s, y + u * s + v * c, top])
            found = _first_hit(model, data, start, down, stops, hit)
            if found[0] > best[0]:
                best = found
        out.append(best)
    return out


def pile_heights(
    model: mujoco.MjModel, data: mujoco.MjData, layout: CellLayout, handles: CellHandles
) -> tuple[FloatArray, FloatArray]:
    """Where a cylinder dropped at each drop spot now comes down [m], with the cylinders lying
    (or standing) in the bin as ``data`` holds them: the height of the highest thing under its
    footprint (the floor where nothing is), and that of the highest cylinder in the band
    behind the spot that a tumbling one may come down on (:func:`tumble_band`; one standing
    0.13 m back of a spot had another land upright on it, its centre above a low bin's rim;
    the floor where none is). Each of shape (number of drop spots,)."""
    found = _landings(model, data, layout, _stops(model, handles, targets=True))
    targets = frozenset(int(g) for g in handles.target_geoms)
    piled = _tumbles(model, data, layout, targets)
    floor = layout.bin.floor_top
    under = np.array([z if g >= 0 else floor for z, g in found])
    behind = np.array([z if g >= 0 else floor for z, g in piled])
    return under, behind


def lying_top(model: mujoco.MjModel, layout: CellLayout, handles: CellHandles) -> float:
    """The highest pile [m] a drop spot may hold and still have room (:func:`spots_with_room`):
    the top of the widest of the cell's cylinders lying on its side on the bin's floor, plus
    :data:`PILE_TOLERANCE` (the published cell: 0.05 + 0.10 + 0.005 = 0.155 m; one standing
    there tops 0.30 m)."""
    widest = float(model.geom_size[list(handles.target_geoms), 0].max())
    return layout.bin.floor_top + 2.0 * widest + PILE_TOLERANCE


def spots_with_room(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    layout: CellLayout,
    handles: CellHandles,
    length: float,
    spots: Sequence[int],
) -> tuple[int, ...]:
    """Those of ``spots`` (0-based) with room for a cylinder ``length`` [m] long dropped now:
    the pile under its footprint is no higher than a cylinder on its side (:func:`lying_top`;
    one dropped on a standing cylinder may topple across its neighbours' tops, see the module
    doc), and should it tumble back onto what stands in the band behind the spot, its centre
    stays below the rim (:func:`pile_heights`)."""
    under, behind = pile_heights(model, data, layout, handles)
    low, rim = lying_top(model, layout, handles), layout.bin.rim
    return tuple(
        s for s in spots if under[s] <= low and max(under[s], behind[s]) + length / 2.0 < rim
    )


def _stops(model: mujoco.MjModel, h: CellHandles, targets: bool) -> frozenset[int]:
    """The geoms a falling target collides with, but the robot's (and the targets, unless
    ``targets``)."""
    t = int(h.target_geoms[0])
    collides = (model.geom_contype & model.geom_conaffinity[t]) | (
        model.geom_contype[t] & model.geom_conaffinity
    )
    passed = set(h.robot_geoms) | (set() if targets else {int(g) for g in h.target_geoms})
    return frozenset(int(g) for g in np.flatnonzero(collides) if int(g) not in passed)


def _landings(
    model: mujoco.MjModel, data: mujoco.MjData, layout: CellLayout, stops: frozenset[int]
) -> list[tuple[float, int]]:
    """Per drop spot, the highest first hit [m] of the rays over a cylinder's footprint
    (:func:`_footprint`) among ``stops``, and its geom (-1 when no ray meets any)."""
    top = layout.bin.rim + 1.0
    down = np.array([0.0, 0.0, -1.0])
    hit = np.zeros(1, dtype=np.int32)
    offsets = _footprint(layout.target.radius)
    out = []
    for x, y in layout.drop_spots[:, :2]:
        best = (-math.inf, -1)
        for dx, dy in offsets:
            found = _first_hit(model, data, np.array([x + dx, y + dy, top]), down, stops, hit)
            if found[0] > best[0]:
                best = found
        out.append(best)
    return out


def _first_hit(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    start: np.ndarray,
    down: np.ndarray,
    stops: frozenset[int],
    hit: np.ndarray,
) -> tuple[float, int]:
    """Height [m] and geom of the first of ``stops`` a ray from ``start`` straight down meets
    (other geoms passed through), or (-inf, -1) when it meets none."""
    p = start.copy()
    for _ in range(64):
        dist = mujoco.mj_ray(model, data, p, down, _GROUPS, 1, -1, hit)
        if dist < 0:
            return -math.inf, -1
        if int(hit[0]) in stops:
            return float(p[2] - dist), int(hit[0])
        p[2] -= dist + 1e-6
    return -math.inf, -1


def usable_drop_spots(blockers: tuple[str, ...]) -> tuple[int, ...]:
    """The drop spots (0-based, in the cell's order) a dropped cylinder reaches the floor from."""
    return tuple(i for i, why in enumerate(blockers) if not why)


def landing_blocker(model: mujoco.MjModel, layout: CellLayout, spot: int) -> str:
    """:func:`landing_blockers` of drop spot ``spot`` alone (1-based)."""
    return landing_blockers(model, layout)[spot - 1]
