"""The ``check`` command: can this cell be served, slot by slot and drop spot by drop spot?

Each row judges the moves a run's cycles really make, with the planner they are planned with
(:meth:`~kr210_sim.plan.planner.Planner.plan_cycle`), before anything runs. A slot's row is the
nominal target's whole cycle from the ready pose, as a run's first cycle plans it: standoff,
grasp, lift and retreat (IK inside the limits; another IK branch when the nearest one cannot
make the cycle), the carry to the drop spot it goes to and the return, each collision-checked
(:mod:`kr210_sim.plan.collide`) and planned around what blocks it (OMPL) where it must be. Its
drop spot is the first usable one (a cylinder dropped there reaches the bin's floor,
:mod:`kr210_sim.plan.landing`) whose carry can be planned: a run carries to them in turn, and
to the next whose carry can be planned. A drop spot's row is first the landing test, then its
carry, release and return from where a cycle's carry starts: the retreat of the first served
slot whose carry reaches it (of the first slot whose pick can be planned, when none is served).
The table says, per row, whether it is reachable, whether a collision-free plan was found, the
drop spot the carry goes to, which planner found it (direct, or OMPL and for which phases), the
gripper's heading at the pick when the radial one collides, the planning time, the length of
the path in joint space and at the gripper, and what blocks otherwise; above it, whether the
ready pose had to be moved clear of the cell.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from functools import partial

import numpy as np
import numpy.typing as npt

from kr210_sim.cell.layout import CellLayout
from kr210_sim.cell.spec import MotionConfig
from kr210_sim.errors import IkFailedError, NoPathError, PlanningError, UnreachablePoseError
from kr210_sim.plan.collide import CollisionChecker
from kr210_sim.plan.cycle import CyclePlan
from kr210_sim.plan.landing import landing_blockers, usable_drop_spots
from kr210_sim.plan.planner import Planner
from kr210_sim.plan.routing import path_lengths
from kr210_sim.robot.description import RobotDescription, load_robot
from kr210_sim.robot.kinematics import Kinematics

import mujoco  # isort: skip

FloatArray = npt.NDArray[np.float64]


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
        drop_spot: The drop spot the row's carry goes to (1-based; for a slot, the one a
            run's first cycle carries to; 0 when none).
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
            f"  {'':<8} {'reachable':>9} {'path':>5} {'drop':>4} {'planner':<22} {'plan ms':>8} "
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
            drop = str(r.drop_spot) if r.path else "-"
            lines.append(
                f"  {r.what:<8} {yes[r.reachable]:>9} {yes[r.path]:>5} {drop:>4} "
                f"{r.planner if r.path else '-':<22} {r.planning_ms:8.1f} {figures}  {detail}"
            )
        return "\n".join(lines)


def _row(
    what: str, planner: Planner, plan: Callable[[], CyclePlan]
) -> tuple[CheckRow, CyclePlan | None]:
    """The row of one plan, and the plan (None when it failed)."""
    t0 = time.perf_counter()
    try:
        cycle = plan()
    except NoPathError as exc:
        ms = 1e3 * (time.perf_counter() - t0)
        return CheckRow(what, True, False, False, ms, str(exc)), None
    except (UnreachablePoseError, IkFailedError, PlanningError) as exc:
        ms = 1e3 * (time.perf_counter() - t0)
        return CheckRow(what, False, False, False, ms, str(exc)), None
    ms = 1e3 * (time.perf_counter() - t0)
    moves = cycle.moves
    ompl = [m.phase for m in moves if m.planner == "ompl"]
    used = f"ompl: {', '.join(dict.fromkeys(ompl))}" if ompl else "direct"
    lengths = [path_lengths(m.trajectory, planner.kinematics) for m in moves]
    joint = sum(a for a, _ in lengths)
    grip = sum(b for _, b in lengths)
    heading = round(math.degrees(cycle.heading_offset), 6)
    row = CheckRow(
        what, True, True, cycle.detours > 0, ms, "", cycle.drop_spot + 1, used, joint, grip, heading
    )
    return row, cycle


#: A slot's note when no drop spot reaches the bin's floor.
NO_DROP_SPOT = "no drop spot can be served: a cylinder dropped at any of them lands above the floor"


@dataclass
class _Check:
    """What a check plans with, and the slot plans it has made."""

    model: mujoco.MjModel
    planner: Planner
    layout: CellLayout
    landing: tuple[str, ...]
    usable: tuple[int, ...]
    plans: dict[int, CyclePlan] = dataclasses.field(default_factory=dict)

    @classmethod
    def of(
        cls, model: mujoco.MjModel, robot: RobotDescription | None, motion: MotionConfig | None
    ) -> _Check:
        layout = CellLayout.from_model(model)
        robot = robot or load_robot()
        kin = Kinematics(robot)
        planner = Planner(robot, motion or MotionConfig(), None, CollisionChecker(model, kin))
        landing = landing_blockers(model, layout)
        return cls(model, planner, layout, landing, usable_drop_spots(landing))

    def target_at(self, n: int) -> FloatArray:
        """The nominal target's centre in slot ``n`` [m]."""
        return self.layout.slots[n - 1] + np.array([0.0, 0.0, self.layout.target.length / 2.0])

    def slot_row(self, n: int) -> CheckRow:
        """Slot ``n``'s row: its first cycle, as a run plans it."""
        layout, planner = self.layout, self.planner
        spots = self.usable or tuple(range(len(layout.drop_spots)))

        def plan() -> CyclePlan:
            ready = planner.ready_q
            return planner.plan_cycle(
                ready, self.target_at(n), layout.target, layout.drop_spots, 0, spots
            )

        row, cycle = _row(f"slot {n}", planner, plan)
        if not self.usable:
            detail = f"{NO_DROP_SPOT}; {row.detail}" if row.detail else NO_DROP_SPOT
            return dataclasses.replace(row, path=False, detail=detail)
        if cycle is not None:
            self.plans[n] = cycle
        return row

    def rows(self) -> Iterator[CheckRow]:
        """The slot rows, planned one by one as they are asked for."""
        return (self.slot_row(n) for n in range(1, self.layout.n_slots + 1))

    def carry_starts(self) -> list[tuple[int, FloatArray]]:
        """Where a cycle's carry starts: the retreat of each served slot (of each slot whose
        pick can be planned when none is), with the slot."""
        if self.plans:
            return [(n, p.end_of("retreat")) for n, p in sorted(self.plans.items())]
        t, starts = self.layout.target, []
        for n in range(1, self.layout.n_slots + 1):
            try:
                grasp = self.planner.plan_grasp(
                    self.planner.ready_q, self.target_at(n), t.radius, t.length
                )
            except (UnreachablePoseError, PlanningError):
                continue
            starts.append((n, grasp.retreat.q_end))
        return starts

    def drop_row(self, n: int, starts: list[tuple[int, FloatArray]]) -> CheckRow:
        """Drop spot ``n``'s row: where a cylinder dropped there lands, then its place from
        the first of ``starts`` that reaches it."""
        what = f"drop {n}"
        if self.landing[n - 1]:
            return CheckRow(what, True, False, False, 0.0, self.landing[n - 1], n)
        if not starts:
            return CheckRow(
                what, False, False, False, 0.0, "no slot's pick can be planned: no carry starts", n
            )
        t = self.layout.target
        first: CheckRow | None = None
        ms = 0.0
        for slot, q in starts:
            row, cycle = _row(
                what,
                self.planner,
                partial(self.planner.plan_place, q, t, self.layout.drop_spots, 0, (n - 1,)),
            )
            ms += row.planning_ms
            if cycle is not None:
                return dataclasses.replace(
                    row, planning_ms=ms, detail=f"carried from slot {slot}'s retreat"
                )
            first = first or row
        assert first is not None
        return dataclasses.replace(
            first,
            planning_ms=ms,
            drop_spot=n,
            detail=f"from slot {starts[0][0]}'s retreat: {first.detail}",
        )


def first_served_slot(
    model: mujoco.MjModel,
    robot: RobotDescription | None = None,
    motion: MotionConfig | None = None,
) -> int:
    """The first slot (1-based) of the cell ``model`` whose cycle can be planned clear (as
    :func:`check_cell` plans it), or 0 when none can: what ``run`` and ``view`` need to know
    before they start, without planning every slot and drop spot."""
    for n, row in enumerate(_Check.of(model, robot, motion).rows(), start=1):
        if row.served:
            return n
    return 0


def check_cell(
    model: mujoco.MjModel,
    robot: RobotDescription | None = None,
    motion: MotionConfig | None = None,
) -> CellCheck:
    """Plan every slot and drop spot of the cell ``model`` simulates (see the module doc)."""
    check = _Check.of(model, robot, motion)
    slots = tuple(check.rows())
    starts = check.carry_starts()
    drops = tuple(check.drop_row(n, starts) for n in range(1, len(check.layout.drop_spots) + 1))
    return CellCheck(check.layout.name, slots, drops, check.planner.ready_note)
