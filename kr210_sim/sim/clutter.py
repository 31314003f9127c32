"""Clutter on the shelf: distractors drawn for every bay, placed at the start of a cycle.

Every bay gets ``per_bay`` objects of the cell's kinds (:mod:`kr210_sim.cell.sensing`), each
standing on its board at rest, none overlapping another or the target: neighbours stand
``gap`` apart (a few millimetres: touching, to the eye and to the camera) or anywhere in the bay.
Nothing stands in the target's *corridor*, the strip the gripper comes in along (radially from
the robot, as :func:`kr210_sim.plan.poses.radial_yaw`), from the front of the shelf to just
behind the target, as wide as the open fingers and the wrist: a distractor may hide part of
the target from a camera, never block the pick. No object of the target's kind stands on the
shelf beside it, so "the right object" is one object.

Objects that are not drawn wait parked off the floor's marked area, as spare targets do.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from kr210_sim.cell.layout import CellLayout
from kr210_sim.cell.sensing import (
    TARGET_KIND,
    TARGET_RGB,
    ClutterSpec,
    ObjectKind,
    clutter_name,
)
from kr210_sim.cell.sensing_layout import clutter_of, kinds_of, pick_list_of
from kr210_sim.cell.spec import SHELF_POST_WIDTH, TargetSpec
from kr210_sim.score.result import TargetSample
from kr210_sim.sim.cell import Cell

import mujoco  # isort: skip

FloatArray = npt.NDArray[np.float64]

#: Half the width of the target's corridor [m]: the open fingers (0.179 m between them, 0.2 m
#: over their outsides) and the wrist behind them, with room to spare.
CORRIDOR_HALF_WIDTH = 0.17
#: How far behind the target's axis the corridor reaches [m]: the fingertips pass the axis by
#: about 0.04 m at the grasp.
CORRIDOR_BEHIND = 0.07
#: Clearance between an object and the shelf's walls and back panel [m].
WALL_CLEARANCE = 0.005
#: Smallest gap between a distractor and the target [m].
TARGET_GAP = 0.01
#: Tries to place one object before it is left out.
TRIES = 40
#: Chance that an object is placed against one already in the bay (rather than anywhere).
CLUSTER_CHANCE = 0.6

_Footprint = tuple[str, FloatArray, tuple[float, float], float]  # shape, centre, half/r, yaw


@dataclass(frozen=True, slots=True)
class Placement:
    """One distractor on the shelf.

    Attributes:
        kind: Its kind's name.
        index: Which of the kind's bodies (0-based).
        slot: The bay (slot number) it stands in.
        position: Its centre in the base frame [m].
        yaw: Its turn about z [rad].
    """

    kind: str
    index: int
    slot: int
    position: tuple[float, float, float]
    yaw: float


def _footprint(kind: ObjectKind, xy: FloatArray, yaw: float) -> _Footprint:
    if kind.shape == "box":
        return ("rect", xy, (kind.size[0] / 2.0, kind.size[1] / 2.0), yaw)
    return ("disc", xy, (kind.size[0], kind.size[0]), 0.0)


def _rect_distance(
    p: FloatArray, centre: FloatArray, half: tuple[float, float], yaw: float
) -> float:
    """Distance from point ``p`` to a turned rectangle (0 inside) [m]."""
    c, s = math.cos(yaw), math.sin(yaw)
    d = p - centre
    lx, ly = c * d[0] + s * d[1], -s * d[0] + c * d[1]
    return math.hypot(max(abs(lx) - half[0], 0.0), max(abs(ly) - half[1], 0.0))


def _rects_apart(a: _Footprint, b: _Footprint, gap: float) -> bool:
    """Separating-axis test of two turned rectangles, each grown by half the gap."""
    corners = []
    for _, centre, half, yaw in (a, b):
        c, s = math.cos(yaw), math.sin(yaw)
        hx, hy = half[0] + gap / 2.0, half[1] + gap / 2.0
        corners.append(
            [
                (centre[0] + c * x - s * y, centre[1] + s * x + c * y)
                for x, y in ((hx, hy), (-hx, hy), (-hx, -hy), (hx, -hy))
            ]
        )
    for yaw in (a[3], b[3]):
        for ax in ((math.cos(yaw), math.sin(yaw)), (-math.sin(yaw), math.cos(yaw))):
            pa = [x * ax[0] + y * ax[1] for x, y in corners[0]]
            pb = [x * ax[0] + y * ax[1] for x, y in corners[1]]
            if max(pa) <= min(pb) or max(pb) <= min(pa):
                return True
    return False


def apart(a: _Footprint, b: _Footprint, gap: float) -> bool:
    """Whether two footprints are at least ``gap`` [m] apart."""
    if a[0] == "disc" and b[0] == "disc":
        return float(np.linalg.norm(a[1] - b[1])) >= a[2][0] + b[2][0] + gap
    if a[0] == "rect" and b[0] == "rect":
        return _rects_apart(a, b, gap)
    disc, rect = (a, b) if a[0] == "disc" else (b, a)
    return _rect_distance(disc[1], rect[1], rect[2], rect[3]) >= disc[2][0] + gap


class Clutter:
    """The cell's distractors: their bodies, and drawing and placing them.

    Args:
        model: The compiled cell model (its ``clutter_<kind>_<j>`` bodies).
        layout: The cell's layout (slots, shelf).
    """

    def __init__(self, model: mujoco.MjModel, layout: CellLayout) -> None:
        self.model, self.layout = model, layout
        self.kinds = {k.name: k for k in kinds_of(model)}
        self.spec: ClutterSpec | None = clutter_of(model)
        self.qpos: dict[str, list[int]] = {}
        self.dof: dict[str, list[int]] = {}
        for name, kind in self.kinds.items():
            joints = [
                mujoco.mj_name2id(
                    model, mujoco.mjtObj.mjOBJ_JOINT, f"{clutter_name(name, j)}_joint"
                )
                for j in range(kind.count)
            ]
            self.qpos[name] = [int(model.jnt_qposadr[j]) for j in joints]
            self.dof[name] = [int(model.jnt_dofadr[j]) for j in joints]
        #: The placements of the last draw.
        self.placed: tuple[Placement, ...] = ()
        #: The kinds picked in turn (the pick list).
        self.picks = pick_list_of(model)
        #: The kind of the cycle's target (set by :meth:`dress_target`).
        self.kind = TARGET_KIND

    @property
    def active(self) -> bool:
        """Whether the cell clutters its shelf."""
        return self.spec is not None and bool(self.kinds)

    def draw(
        self,
        rng: np.random.Generator,
        target_slot: int = 0,
        target_xy: npt.ArrayLike | None = None,
        target_radius: float = 0.05,
        target_kind: str = "target",
    ) -> tuple[Placement, ...]:
        """Draw the distractors of every bay.

        Args:
            rng: The generator drawn from.
            target_slot: The target's slot (0: none).
            target_xy: Where the target stands (x, y) [m] (its corridor is kept clear in its
                slot), or None for no target.
            target_radius: The target's radius [m].
            target_kind: The target's kind (none of it is drawn).
        """
        if not self.active:
            return ()
        assert self.spec is not None
        left = {n: list(range(k.count)) for n, k in self.kinds.items() if n != target_kind}
        out: list[Placement] = []
        txy = None if target_xy is None else np.asarray(target_xy, dtype=np.float64)[:2]
        for slot in rng.permutation(np.arange(1, self.layout.n_slots + 1)).tolist():
            taken: list[_Footprint] = []
            board = self.layout.slots[slot - 1]
            keep_out: list[_Footprint] = []
            if txy is not None and slot == target_slot:
                keep_out = self._corridor(txy, target_radius)
            n = int(rng.integers(self.spec.per_bay[0], self.spec.per_bay[1] + 1))
            for _ in range(n):
                kinds = [k for k, idx in left.items() if idx]
                if not kinds:
                    break
                kind = self.kinds[kinds[int(rng.integers(len(kinds)))]]
                spot = self._find_spot(rng, kind, board, taken, keep_out)
                if spot is None:
                    continue
                xy, yaw = spot
                taken.append(_footprint(kind, xy, yaw))
                j = left[kind.name].pop(0)
                z = float(board[2]) + kind.half_extents[2]
                out.append(Placement(kind.name, j, slot, (float(xy[0]), float(xy[1]), z), yaw))
        return tuple(out)

    def _bay_half_width(self) -> float:
        ys = sorted({round(float(self.layout.shelf.local(s)[1]), 6) for s in self.layout.slots})
        pitch = ys[1] - ys[0] if len(ys) > 1 else 2.0 * float(self.layout.shelf.half[1])
        return pitch / 2.0

    def _corridor(self, txy: FloatArray, radius: float) -> list[_Footprint]:
        """The target's disc and the strip the gripper comes in along."""
        heading = math.atan2(txy[1], txy[0])
        u = np.array([math.cos(heading), math.sin(heading)])
        length = float(np.linalg.norm(txy))  # from the robot's axis to just behind the target
        far = CORRIDOR_BEHIND
        centre = txy + u * (far - length / 2.0)
        strip: _Footprint = ("rect", centre, ((length + far) / 2.0, CORRIDOR_HALF_WIDTH), heading)
        disc: _Footprint = ("disc", txy, (radius + TARGET_GAP, radius + TARGET_GAP), 0.0)
        return [disc, strip]

    def _inside_bay(self, fp: _Footprint, board: FloatArray) -> bool:
        """Whether a footprint stands within the bay of the slot at ``board`` (walls, back)."""
        shelf = self.layout.shelf
        lc = shelf.local(board)
        half_w = self._bay_half_width() - SHELF_POST_WIDTH / 2.0 - WALL_CLEARANCE
        x_lo = -float(shelf.half[0]) + WALL_CLEARANCE
        x_hi = float(shelf.half[0]) - 0.02 - WALL_CLEARANCE  # the back panel
        shape, centre, half, yaw = fp
        local = shelf.local((*centre, board[2]))
        if shape == "disc":
            ex = ey = half[0]
        else:
            shelf_yaw = math.atan2(shelf.R[1, 0], shelf.R[0, 0])
            c, s = abs(math.cos(yaw - shelf_yaw)), abs(math.sin(yaw - shelf_yaw))
            ex, ey = c * half[0] + s * half[1], s * half[0] + c * half[1]
        return bool(x_lo + ex <= local[0] <= x_hi - ex and abs(local[1] - lc[1]) <= half_w - ey)

    def _find_spot(
        self,
        rng: np.random.Generator,
        kind: ObjectKind,
        board: FloatArray,
        taken: list[_Footprint],
        keep_out: list[_Footprint],
    ) -> tuple[FloatArray, float] | None:
        assert self.spec is not None
        shelf = self.layout.shelf
        lc = shelf.local(board)
        half_w = self._bay_half_width()
        for _ in range(TRIES):
            yaw = float(rng.uniform(-math.pi, math.pi))
            if taken and rng.random() < CLUSTER_CHANCE:  # against a neighbour
                other = taken[int(rng.integers(len(taken)))]
                gap = float(rng.uniform(*self.spec.gap))
                a = float(rng.uniform(-math.pi, math.pi))
                reach = other[2][0] if other[0] == "disc" else math.hypot(*other[2])
                r = reach + kind.footprint_radius + gap
                xy = other[1] + r * np.array([math.cos(a), math.sin(a)])
                if other[0] == "rect" or kind.shape == "box":  # slide in until nearly touching
                    xy = self._slide(kind, yaw, other[1], xy, taken + keep_out, gap)
            else:
                lx = float(rng.uniform(-shelf.half[0], shelf.half[0]))
                ly = float(lc[1] + rng.uniform(-half_w, half_w))
                xy = (shelf.center + shelf.R @ np.array([lx, ly, 0.0]))[:2]
            fp = _footprint(kind, xy, yaw)
            if not self._inside_bay(fp, board):
                continue
            gap_lo = self.spec.gap[0]
            if all(apart(fp, o, gap_lo) for o in taken) and all(
                apart(fp, o, 0.0) for o in keep_out
            ):
                return xy, yaw
        return None

    @staticmethod
    def _slide(
        kind: ObjectKind,
        yaw: float,
        towards: FloatArray,
        xy: FloatArray,
        others: list[_Footprint],
        gap: float,
    ) -> FloatArray:
        """Move ``xy`` towards ``towards`` while the footprint stays ``gap`` clear of
        ``others`` (boxes' circumscribed discs leave wide gaps otherwise)."""
        step = towards - xy
        lo, hi = 0.0, 1.0
        for _ in range(12):
            mid = (lo + hi) / 2.0
            fp = _footprint(kind, xy + mid * step, yaw)
            if all(apart(fp, o, gap) for o in others):
                lo = mid
            else:
                hi = mid
        return xy + lo * step

    def dress_target(self, sample: TargetSample, index: int) -> TargetSample:
        """Cycle ``index``'s target (1-based) made as the pick list's kind for that cycle: the
        drawn sample unchanged for the cell's own target, else the kind's size, mass and
        friction standing on the same board (:meth:`scatter` gives it the kind's colour)."""
        self.kind = self.picks[(index - 1) % len(self.picks)]
        if self.kind == TARGET_KIND:
            return sample
        spec, _ = pick_target(self.kind, self.layout, self.kinds)
        x, y, z = sample.position
        board = z - sample.spec.length / 2.0
        position = (x, y, board + spec.length / 2.0)
        return dataclasses.replace(sample, spec=spec, position=position)

    def scatter(
        self,
        cell: Cell,
        k: int,
        sample: TargetSample,
        index: int,
        rng: np.random.Generator | None = None,
    ) -> tuple[Placement, ...]:
        """Colour target ``k`` (spawned as ``sample``) as its kind, and clutter the shelf for
        cycle ``index`` around it: drawn from ``rng`` (``--randomize``: the run's generator),
        else from the cell's clutter seed and the cycle (the same shelf every run). A tidy
        shelf is left as it is.

        Returns:
            The placements (none on a tidy shelf).
        """
        _, rgb = pick_target(self.kind, self.layout, self.kinds)
        self.model.geom_rgba[int(cell.handles.target_geoms[k]), :3] = rgb
        if not self.active:
            return ()
        assert self.spec is not None
        gen = rng if rng is not None else np.random.default_rng([self.spec.seed, index])
        xy = sample.position[:2]
        placements = self.draw(gen, sample.slot, xy, sample.spec.radius, self.kind)
        self.place(cell.data, placements)
        mujoco.mj_forward(self.model, cell.data)
        return placements

    def place(self, data: mujoco.MjData, placements: tuple[Placement, ...]) -> None:
        """Park every distractor, then stand the drawn ones at rest where drawn (no step
        taken; call :func:`mujoco.mj_forward` after)."""
        for name, addrs in self.qpos.items():
            for j, a in enumerate(addrs):
                data.qpos[a : a + 7] = self.model.qpos0[a : a + 7]
                d = self.dof[name][j]
                data.qvel[d : d + 6] = 0.0
        for p in placements:
            a = self.qpos[p.kind][p.index]
            data.qpos[a : a + 3] = p.position
            data.qpos[a + 3 : a + 7] = (math.cos(p.yaw / 2), 0.0, 0.0, math.sin(p.yaw / 2))
        self.placed = placements


def pick_target(
    kind: str,
    layout: CellLayout,
    kinds: dict[str, ObjectKind],
    rng: np.random.Generator | None = None,
) -> tuple[TargetSpec, tuple[float, float, float]]:
    """The target cylinder made as pick kind ``kind``: its size, mass and friction, and its
    colour.

    The cell's own target ("target") is the layout's, its size, mass and friction drawn from the
    randomisation ranges when ``rng`` is given (as ``--randomize`` draws it); another kind's are
    its own (a product has one size).
    """
    if kind == TARGET_KIND:
        if rng is None:
            return layout.target, TARGET_RGB
        r = layout.randomization
        spec = TargetSpec(
            radius=float(rng.uniform(*r.radius)),
            length=float(rng.uniform(*r.length)),
            mass=float(rng.uniform(*r.mass)),
            friction=float(rng.uniform(*r.friction)),
        )
        return spec, TARGET_RGB
    k = kinds[kind]
    spec = TargetSpec(radius=k.size[0], length=k.size[1], mass=k.mass, friction=k.friction)
    return spec, k.rgb
