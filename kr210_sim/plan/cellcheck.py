"""The ``check`` command: can this cell be served, slot by slot and drop spot by drop spot?

For every slot the nominal target's whole cycle is planned as the first cycle of a run plans it
(:meth:`~kr210_sim.plan.planner.Planner.plan_cycle`), before anything runs: standoff, grasp,
lift and retreat (IK inside the limits), the carry to the drop spot the run picks first and the
return, each collision-checked (:mod:`kr210_sim.plan.collide`) and detoured where it must be.
Every drop spot is planned from the ready pose with the target held. The table says, per row,
whether it is reachable, whether a collision-free plan was found, whether it needed a detour,
what blocks otherwise, and the planning time.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np

from kr210_sim.cell.layout import CellLayout
from kr210_sim.cell.spec import MotionConfig
from kr210_sim.errors import IkFailedError, NoPathError, PlanningError, UnreachablePoseError
from kr210_sim.plan.collide import CollisionChecker
from kr210_sim.plan.cycle import drop_spot_index
from kr210_sim.plan.planner import Planner
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
        detour: The plan goes through via points.
        planning_ms: Wall time of the planning [ms].
        detail: What blocks (empty when served).
        drop_spot: The drop spot the row's carry goes to (1-based; for a slot, the one the
            run's first cycle picks).
    """

    what: str
    reachable: bool
    path: bool
    detour: bool
    planning_ms: float
    detail: str
    drop_spot: int = 0

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
    """

    name: str
    slots: tuple[CheckRow, ...]
    drops: tuple[CheckRow, ...]

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
        head = f"cell {self.name}: {verdict}"
        lines = [
            head,
            f"  {'':<8} {'reachable':>9} {'path':>5} {'detour':>6} {'plan ms':>8}  blocked by",
        ]
        for r in (*self.slots, *self.drops):
            yes = {True: "yes", False: "no"}
            lines.append(
                f"  {r.what:<8} {yes[r.reachable]:>9} {yes[r.path]:>5} "
                f"{yes[r.detour] if r.path else '-':>6} {r.planning_ms:8.1f}  {r.detail}"
            )
        return "\n".join(lines)


def _row(what: str, drop_spot: int, planner: Planner, plan: Callable[[], object]) -> CheckRow:
    detours = planner.detours
    t0 = time.perf_counter()
    try:
        plan()
    except NoPathError as exc:
        ms = 1e3 * (time.perf_counter() - t0)
        return CheckRow(what, True, False, False, ms, str(exc), drop_spot)
    except (UnreachablePoseError, IkFailedError, PlanningError) as exc:
        ms = 1e3 * (time.perf_counter() - t0)
        return CheckRow(what, False, False, False, ms, str(exc), drop_spot)
    ms = 1e3 * (time.perf_counter() - t0)
    return CheckRow(what, True, True, planner.detours > detours, ms, "", drop_spot)


def check_cell(
    model: mujoco.MjModel,
    robot: RobotDescription | None = None,
    motion: MotionConfig | None = None,
) -> CellCheck:
    """Plan every slot and drop spot of the cell ``model`` simulates (see the module doc)."""
    layout = CellLayout.from_model(model)
    robot = robot or load_robot()
    planner = Planner(
        robot, motion or MotionConfig(), None, CollisionChecker(model, Kinematics(robot))
    )
    t = layout.target
    ready = planner.ready_q
    first = drop_spot_index(0, len(layout.drop_spots)) + 1  # a run's first cycle's

    def slot_plan(n: int) -> None:
        p = layout.slots[n - 1] + np.array([0.0, 0.0, t.length / 2.0])
        planner.plan_cycle(ready, p, t, layout.drop_spots)

    def drop_plan(n: int) -> None:  # the place part of a cycle, from the ready pose
        planner.plan_place(ready, t, layout.drop_spots, placed=n - 1)

    slots = tuple(
        _row(f"slot {n}", first, planner, partial(slot_plan, n))
        for n in range(1, layout.n_slots + 1)
    )
    drops = tuple(
        _row(f"drop {n}", n, planner, partial(drop_plan, n))
        for n in range(1, len(layout.drop_spots) + 1)
    )
    return CellCheck(layout.name, slots, drops)
