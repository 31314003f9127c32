"""The cell's target cylinders: spares waiting off to the side, one in play, the rest where
their cycles left them.

A run takes a fresh spare for every cycle. No cylinder moves unless the run says so: when no
spare is left, the operator empties the bin and picks up the cylinders that fell elsewhere
(:meth:`TargetPool.restock`), and a cylinder knocked over on the shelf is cleared off it
(:meth:`TargetPool.clear`). Each is an :class:`Event` that the report records and the video
shows; the cylinders never leave the bin unseen.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from kr210_sim.cell.layout import BinBox, CellLayout
from kr210_sim.cell.spec import TargetSpec
from kr210_sim.score.result import Event, EventKind
from kr210_sim.score.scoring import in_bin
from kr210_sim.sim.cell import Cell

import mujoco  # isort: skip

FloatArray = npt.NDArray[np.float64]


def set_target_spec(
    model: mujoco.MjModel,
    cell: Cell,
    index: int,
    spec: TargetSpec,
    rgb: tuple[float, float, float] | None = None,
) -> None:
    """Give target ``index`` the size, mass and friction of ``spec`` (model fields), and the
    colour ``rgb`` of the kind it is made as (None: leave it)."""
    h = cell.handles
    g, b = int(h.target_geoms[index]), int(h.target_bodies[index])
    if rgb is not None:
        model.geom_rgba[g, :3] = rgb
    r, half = spec.radius, spec.length / 2.0
    model.geom_size[g, :2] = (r, half)
    model.geom_rbound[g] = math.hypot(r, half)
    model.geom_aabb[g] = (0, 0, 0, r, r, half)
    model.geom_friction[g, 0] = spec.friction
    model.body_mass[b] = spec.mass
    ixx = spec.mass * (3 * r * r + spec.length**2) / 12.0
    model.body_inertia[b] = (ixx, ixx, spec.mass * r * r / 2.0)
    # Recompute the derived constants (inverse weights the constraint solver scales by) on a
    # scratch MjData, so the live state is untouched.
    mujoco.mj_setConst(model, mujoco.MjData(model))


def place_upright(cell: Cell, k: int, position: npt.ArrayLike, yaw: float = 0.0) -> None:
    """Put cylinder ``k`` upright at ``position`` [m] with ``yaw`` [rad], at rest (no step
    taken)."""
    h, d = cell.handles, cell.data
    a, dof = int(h.target_qpos[k]), int(h.target_dof[k])
    d.qpos[a : a + 3] = np.asarray(position, dtype=np.float64)
    d.qpos[a + 3 : a + 7] = (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))
    cell.nudge(np.arange(a, a + 3))
    d.qvel[dof : dof + 6] = 0.0


class TargetPool:
    """Which cylinder is spare, which is in play; spawning, clearing and restocking.

    Args:
        cell: The simulated cell (its model holds the cylinders ``target_0`` ...).
        layout: The cell's layout as the model holds it (where spares are parked, the bin).
    """

    def __init__(self, cell: Cell, layout: CellLayout) -> None:
        self.cell = cell
        self.layout = layout
        self.spare = list(range(len(cell.handles.target_bodies)))
        self.in_play: list[int] = []
        self.events: list[Event] = []

    @property
    def bin(self) -> BinBox:
        """The bin's inside."""
        return self.layout.bin

    def in_bin_count(self) -> int:
        """Cylinders lying in the bin now."""
        return sum(in_bin(self.cell.target_pose(k)[0], self.bin) for k in self.in_play)

    def _place(self, k: int, position: npt.ArrayLike, yaw: float = 0.0) -> None:
        place_upright(self.cell, k, position, yaw)

    def restock(self, before_cycle: int, keep: int | None = None, why: str = "") -> Event:
        """Empty the bin and pick up every cylinder in play: all become spares again, parked.

        Args:
            before_cycle: The cycle the event comes before.
            keep: A cylinder in play left where it is, still in play (the one a cycle is about
                to pick), or None.
            why: Why the bin is emptied, for the event's detail ("" when no spare is left).
        """
        moved = tuple(k for k in self.in_play if k != keep)
        in_bin_n = sum(in_bin(self.cell.target_pose(k)[0], self.bin) for k in moved)
        for k in moved:
            self._place(k, self.layout.park[k])
        mujoco.mj_forward(self.cell.model, self.cell.data)
        self.spare = sorted(self.spare + list(moved))
        self.in_play = [keep] if keep is not None and keep in self.in_play else []
        elsewhere = len(moved) - in_bin_n
        detail = f"the bin was emptied ({in_bin_n} cylinders)" + (
            f" and {elsewhere} cylinders outside it were picked up" if elsewhere else ""
        )
        detail += f": {why}" if why else ""
        event = Event(EventKind.BIN_EMPTIED, before_cycle, self.cell.time, moved, detail)
        self.events.append(event)
        return event

    def spawn(self, position: npt.ArrayLike, yaw: float, spec: TargetSpec) -> int:
        """Put the first spare cylinder, made to ``spec``, upright at ``position`` [m] with
        ``yaw`` [rad]; it becomes the cell's active target.

        Returns:
            The cylinder's index.

        Raises:
            IndexError: When no spare is left (:meth:`restock` first).
        """
        k = self.spare.pop(0)
        self.in_play.append(k)
        set_target_spec(self.cell.model, self.cell, k, spec)
        self._place(k, position, yaw)
        self.cell.active_target = k
        mujoco.mj_forward(self.cell.model, self.cell.data)
        return k

    def clear(self, k: int, before_cycle: int, reason: str) -> Event:
        """Take cylinder ``k`` off the shelf to its parking spot (it stays out of play until the
        next restock), as an event."""
        self._place(k, self.layout.park[k])
        mujoco.mj_forward(self.cell.model, self.cell.data)
        event = Event(
            EventKind.SHELF_CLEARED,
            before_cycle,
            self.cell.time,
            (k,),
            f"cylinder {k} was taken off the shelf ({reason})",
        )
        self.events.append(event)
        return event
