"""The ``check`` command: can this cell be served, slot by slot and drop spot by drop spot?

For every slot the nominal target's whole cycle is planned as the first cycle of a run plans it
(:meth:`~kr210_sim.plan.planner.Planner.plan_cycle`), before anything runs: standoff, grasp,
lift and retreat (IK inside the limits), the carry to the drop spot the run picks first and the
return, each collision-checked (:mod:`kr210_sim.plan.collide`) and planned around what blocks it
(OMPL) where it must be.
Every drop spot is planned from the ready pose with the target held. The table says, per row,
whether it is reachable, whether a collision-free plan was found, which planner found it
(direct, or OMPL and for which phases), the gripper's heading at the pick when the radial one
collides, the planning time, the length of the path in joint
space and at the gripper, and what blocks otherwise; above it, whether the ready pose had to be
moved clear of the cell.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from functools import partial

import numpy as np

from kr210_sim.cell.layout import CellLayout
from kr210_sim.cell.spec import MotionConfig
from kr210_sim.errors import IkFailedError, NoPathError, PlanningError, UnreachablePoseError
from kr210_sim.plan.collide import CollisionChecker
from kr210_sim.plan.cycle import CyclePlan, drop_spot_index
from kr210_sim.plan.planner import Planner
from kr210_sim.plan.routing import path_lengths
from kr210_sim.robot.description import RobotDescription, load_robot
from kr210_sim.robot.kinematics import Kinematics

import mujoco  # isort: skip


@dataclass(frozen=True, slots=True)
class CheckRow:
    """One slot or drop spot.

    Attributes:
        what: "slot 3" or "drop 2".
        reachable: IK inside the joint limits for every pose it needs.
        path: A collision-free plan was found.
        detour: A move of the plan was planned by OMPL around what blocked its direct move.
        planning_ms: Wall time of the planning [ms].
        detail: What blocks (empty when served).
        drop_spot: The drop spot the row's carry goes to (1-based; for a slot, the one the
            run's first cycle picks).
        planner: "direct", or "ompl" and the phases OMPL planned ("ompl: approach, carry").
        joint_length: Length of the plan's path in joint space [rad].
        gripper_length: Length of the gripper's path [m].
        heading_deg: The gripper's heading at the pick off the radial one [deg] (0 unless
            the radial pick collides).
    """

    what: str
    reachable: bool
    path: bool
    detour: bool
    planning_ms: float
    detail: str
    drop_spot: int = 0
    planner: str = ""
    joint_length: float = 0.0
    gripper_length: float = 0.0
    heading_deg: float = 0.0

    @property
    def served(self) -> bool:
        """Reachable with a collision-free plan."""
        return self.reachable and self.path


@dataclass(frozen=True, slots=True)
class CellCheck:
    """The check of a whole cell.

    Attributes:
        name: The cell's name.
        slots: One row per slot.
        drops: One row per drop spot.
        ready_note: What blocked the configured ready pose and how far the clear one used
            instead lies from it (empty when it was clear).
    """

    name: str
    slots: tuple[CheckRow, ...]
    drops: tuple[CheckRow, ...]
    ready_note: str = ""

    @property
    def ok(self) -> bool:
        """Every slot and every drop spot can be served."""
        return all(r.served for r in (*self.slots, *self.drops))

    @property
    def any_slot(self) -> bool:
        """At least one slot can be served."""
        return any(r.served for r in self.slots)

    def table(self) -> str:
        """A plain-text table, one line per slot and drop spot."""
        verdict = "every slot and drop spot can be served" if self.ok else "NOT SERVED"
        lines = [f"cell {self.name}: {verdict}"]
        if self.ready_note:
            lines.append(f"  ready pose: {self.ready_note}")
        lines.append(
            f"  {'':<8} {'reachable':>9} {'path':>5} {'planner':<22} {'plan ms':>8} "
            f"{'joint rad':>9} {'gripper m':>9}  blocked by (or note)"
        )
        yes = {True: "yes", False: "no"}
        for r in (*self.slots, *self.drops):
            detail = r.detail
            if r.path:
                figures = f"{r.joint_length:9.2f} {r.gripper_length:9.2f}"
                if r.heading_deg:
                    detail = f"picked {r.heading_deg:+.0f} deg off the radial (that one collides)"
            else:
                figures = f"{'-':>9} {'-':>9}"
            lines.append(
                f"  {r.what:<8} {yes[r.reachable]:>9} {yes[r.path]:>5} "
                f"{r.planner if r.path else '-':<22} {r.planning_ms:8.1f} {figures}  {detail}"
            )
        return "\n".join(lines)


def _row(what: str, drop_spot: int, planner: Planner, plan: Callable[[], CyclePlan]) -> CheckRow:
    detours = planner.detours
    t0 = time.perf_counter()
    try:
        cycle = plan()
    except NoPathError as exc:
        ms = 1e3 * (time.perf_counter() - t0)
        return CheckRow(what, True, False, False, ms, str(exc), drop_spot)
    except (UnreachablePoseError, IkFailedError, PlanningError) as exc:
        ms = 1e3 * (time.perf_counter() - t0)
        return CheckRow(what, False, False, False, ms, str(exc), drop_spot)
    ms = 1e3 * (time.perf_counter() - t0)
    moves = cycle.moves
    ompl = [m.phase for m in moves if m.planner == "ompl"]
    used = f"ompl: {', '.join(dict.fromkeys(ompl))}" if ompl else "direct"
    lengths = [path_lengths(m.trajectory, planner.kinematics) for m in moves]
    joint = sum(a for a, _ in lengths)
    grip = sum(b for _, b in lengths)
    detour = planner.detours > detours
    heading = round(math.degrees(cycle.heading_offset), 6)
    return CheckRow(what, True, True, detour, ms, "", drop_spot, used, joint, grip, heading)


#: Geom groups of colliders (cell parts 0, robot and dressing colliders 3): what a dropped
#: cylinder can land on.
_COLLIDER_GROUPS = np.array([1, 0, 0, 1, 0, 0], dtype=np.uint8)


def landing_blocker(model: mujoco.MjModel, layout: CellLayout, spot: int) -> str:
    """What stops a cylinder dropped at drop spot ``spot`` (1-based) above the bin's floor, or
    "" when it falls to the floor (a box in the bin: every cycle would end ``missed_bin``).

    Rays straight down from above the rim, at the spot and four points on the cylinder's
    rim, against the colliders of the model at its first keyframe.
    """
    data = mujoco.MjData(model)
    if model.nkey:
        mujoco.mj_resetDataKeyframe(model, data, 0)
    mujoco.mj_forward(model, data)
    b, r = layout.bin, layout.target.radius
    x, y = layout.drop_spots[spot - 1][:2]
    top = b.rim + 1.0
    hit = np.zeros(1, dtype=np.int32)
    for dx, dy in ((0.0, 0.0), (r, 0.0), (-r, 0.0), (0.0, r), (0.0, -r)):
        start = np.array([x + dx, y + dy, top])
        dist = mujoco.mj_ray(
            model, data, start, np.array([0.0, 0.0, -1.0]), _COLLIDER_GROUPS, 1, -1, hit
        )
        if dist >= 0 and top - dist > b.floor_top + 0.005:
            body = model.body(int(model.geom_bodyid[hit[0]])).name or "a geom"
            return (
                f"a cylinder dropped here lands on {body} at z = {top - dist:.2f} m, above the "
                f"bin's floor ({b.floor_top:.2f} m)"
            )
    return ""


def _landing(model: mujoco.MjModel, layout: CellLayout, spot: int, row: CheckRow) -> CheckRow:
    """``row`` of drop spot ``spot``, not served when a dropped cylinder cannot reach the
    bin's floor."""
    blocker = landing_blocker(model, layout, spot) if row.served else ""
    return dataclasses.replace(row, path=False, detail=blocker) if blocker else row


def _slot_rows(
    model: mujoco.MjModel, robot: RobotDescription | None, motion: MotionConfig | None
) -> tuple[Planner, CellLayout, Iterator[CheckRow]]:
    """The planner and layout of a check, and its slot rows, planned one by one as they are
    asked for."""
    layout = CellLayout.from_model(model)
    robot = robot or load_robot()
    planner = Planner(
        robot, motion or MotionConfig(), None, CollisionChecker(model, Kinematics(robot))
    )
    t = layout.target
    first = drop_spot_index(0, len(layout.drop_spots)) + 1  # a run's first cycle's

    def slot_plan(n: int) -> CyclePlan:
        p = layout.slots[n - 1] + np.array([0.0, 0.0, t.length / 2.0])
        return planner.plan_cycle(planner.ready_q, p, t, layout.drop_spots)

    rows = (
        _row(f"slot {n}", first, planner, partial(slot_plan, n))
        for n in range(1, layout.n_slots + 1)
    )
    return planner, layout, rows


def first_served_slot(
    model: mujoco.MjModel,
    robot: RobotDescription | None = None,
    motion: MotionConfig | None = None,
) -> int:
    """The first slot (1-based) of the cell ``model`` whose cycle can be planned clear (as
    :func:`check_cell` plans it), or 0 when none can: what ``run`` and ``view`` need to know
    before they start, without planning every slot and drop spot."""
    _, _, rows = _slot_rows(model, robot, motion)
    for n, row in enumerate(rows, start=1):
        if row.served:
            return n
    return 0


def check_cell(
    model: mujoco.MjModel,
    robot: RobotDescription | None = None,
    motion: MotionConfig | None = None,
) -> CellCheck:
    """Plan every slot and drop spot of the cell ``model`` simulates (see the module doc)."""
    planner, layout, rows = _slot_rows(model, robot, motion)
    slots = tuple(rows)
    t = layout.target

    def drop_plan(n: int) -> CyclePlan:  # the place part of a cycle, from the ready pose
        return planner.plan_place(planner.ready_q, t, layout.drop_spots, placed=n - 1)

    drops = tuple(
        _landing(model, layout, n, _row(f"drop {n}", n, planner, partial(drop_plan, n)))
        for n in range(1, len(layout.drop_spots) + 1)
    )
    return CellCheck(layout.name, slots, drops, planner.ready_note)
