"""One pick-and-place cycle as the planner returns it: its steps in order, each in a phase.

:meth:`kr210_sim.plan.planner.Planner.plan_cycle` builds a :class:`CyclePlan`; the runner
executes it, the Gymnasium expert turns it into actions, ``check`` plans one per slot, ``ik-check``
takes its poses and view's demo mode stops before each of its phases. A step is an arm move
(:class:`Move`) or a grip (:class:`Grip`); the phase names are the steps' own, so a new phase is
one more step in ``plan_cycle`` and nothing else.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from enum import StrEnum

import numpy as np
import numpy.typing as npt

from kr210_sim.plan.trajectory import Trajectory

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class Move:
    """One arm motion of a cycle.

    Attributes:
        phase: Phase name (approach, lift, retreat, carry, return).
        kind: "ptp" (joint space) or "lin" (straight line in Cartesian space).
        trajectory: The time-parametrised joint trajectory.
        planner: "direct" (the straight joint move or line) or "ompl" (a path planned around
            what blocks the direct move, :mod:`kr210_sim.plan.routing`).
        planning_time: Wall time of its planning and collision checks [s].
        bound: Lower bound of its duration at the joint velocity and acceleration limits (and,
            for a line, the Cartesian speed) [s]; 0 when not known.
    """

    phase: str
    kind: str
    trajectory: Trajectory
    planner: str = "direct"
    planning_time: float = 0.0
    bound: float = 0.0

    @property
    def q_end(self) -> FloatArray:
        """Joint state at the end of the move [rad]."""
        return self.trajectory.sample(self.trajectory.duration)[0]


class Grip(StrEnum):
    """What a grip step does to the gripper."""

    CLOSE = "close"
    OPEN = "open"


@dataclass(frozen=True, slots=True)
class Step:
    """One step of a cycle: an arm move or a grip, never both.

    Attributes:
        phase: Phase name (what the runner records, the video shows, demo mode stops before).
        move: The arm motion, or None for a grip step.
        grip: Close or open the gripper, or None for a move.
        wait: Time a grip step takes [s]: the longest wait for a confirmed grip (close), the
            wait before the arm leaves (open); 0 for a move.
        pose: Name of the gripper pose the move ends at ("standoff", "grasp", "lift",
            "retreat", "drop"); empty for a grip step or a move to a joint state (the return).
        T: That gripper_link pose (4x4, world frame), or None.
    """

    phase: str
    move: Move | None = None
    grip: Grip | None = None
    wait: float = 0.0
    pose: str = ""
    T: FloatArray | None = None


@dataclass(frozen=True, slots=True)
class CyclePlan:
    """The whole cycle, planned (and collision-checked) before the arm moves.

    Attributes:
        steps: The steps in order.
        drop_spot: Index of the drop spot the carry goes to (0-based, in the cell's order).
        drop_xy: That drop spot [m].
        detours: Moves of this plan planned by OMPL around what blocked their direct move.
        wall_time: Wall-clock time of the planning [s].
        cpu_time: CPU time of the planning [s].
        heading_offset: The gripper's heading at the pick off the radial one [rad] (0 unless
            the radial pick collides, :meth:`~kr210_sim.plan.planner.Planner.plan_grasp`).
    """

    steps: tuple[Step, ...]
    drop_spot: int
    drop_xy: tuple[float, float]
    detours: int
    wall_time: float
    cpu_time: float
    heading_offset: float = 0.0

    @property
    def phases(self) -> tuple[str, ...]:
        """The phase names in order, consecutive repeats once (the approach is two moves)."""
        out: list[str] = []
        for step in self.steps:
            if not out or out[-1] != step.phase:
                out.append(step.phase)
        return tuple(out)

    @property
    def moves(self) -> tuple[Move, ...]:
        """The arm moves in order."""
        return tuple(s.move for s in self.steps if s.move is not None)

    def end_of(self, pose: str) -> FloatArray:
        """Joint state [rad] at the end of the move to the named gripper pose.

        Raises:
            KeyError: When no move of the plan ends at ``pose``.
        """
        for step in self.steps:
            if step.pose == pose and step.move is not None:
                return step.move.q_end
        raise KeyError(f"no move of the cycle ends at the {pose!r} pose")


def drop_spot_index(placed: int, n_spots: int) -> int:
    """The drop spot of the next carry among ``n_spots``: the spots in turn, from the first
    after the bin is emptied.

    Args:
        placed: Targets put in play since the bin was last emptied, this cycle's not counted.
        n_spots: Drop spots to choose from.
    """
    return placed % n_spots


def drop_spot_order(
    placed: int,
    spots: Sequence[int],
    dropped: Sequence[int] | None = None,
    turn: Sequence[int] | None = None,
) -> tuple[int, ...]:
    """The drop spots the next carry tries, in order: the one in turn among ``spots``
    (:func:`drop_spot_index`), then the others in turn after it; with ``dropped``, the spots
    fewest cylinders were carried to since the bin was emptied come first (in that order among
    equals), so that cylinders spread over the bin when some spots cannot be reached. A carry
    goes to the first whose place (carry, release, return) can be planned.

    Args:
        placed: As :func:`drop_spot_index`.
        spots: The drop spots to use (0-based, in the cell's order): those a dropped cylinder
            reaches the bin's floor from (:func:`~kr210_sim.plan.landing.usable_drop_spots`).
        dropped: Cylinders carried to each of the cell's drop spots since the bin was emptied
            (indexed by spot), or None.
        turn: The spots the turn goes over, when ``spots`` are some of them (a run's usable
            spots, ``spots`` those with room for another cylinder): the one in turn among
            ``turn``, or the first of ``spots`` after it, and so on, so that a spot with no
            room does not shift the turn of the others. Default: ``spots``.
    """
    over = tuple(spots) if turn is None else tuple(turn)
    n = len(over)
    first = drop_spot_index(placed, n) if n else 0
    use = set(spots)
    order = [s for s in (over[(first + i) % n] for i in range(n)) if s in use]
    order += [s for s in spots if s not in over]
    if dropped is not None:
        order.sort(key=lambda s: dropped[s])  # stable: in turn among equals
    return tuple(order)


def pick_order(n_spots: int, n_branches: int) -> Iterator[tuple[int, int]]:
    """The (drop spot rank, IK branch) pairs a cycle tries, in order: by rank + branch, and
    among equal sums the drop spot earlier in turn first: (0, 0), (0, 1), (1, 0), (0, 2), ...

    A pick whose carry cannot be planned from its nearest branch's retreat (a wrist turned over,
    as a ready pose facing away leaves it: the held target tilts too far on every carry) is
    found on the next branch after one failed carry, not after one for every drop spot; a drop
    spot no carry reaches costs about one more.

    Args:
        n_spots: Drop spots in the order to try them (rank 0: the one in turn).
        n_branches: IK branches of the standoff at most (rank 0: the nearest the start).
    """
    for total in range(n_spots + n_branches - 1):
        for rank in range(max(0, total - n_branches + 1), min(total, n_spots - 1) + 1):
            yield rank, total - rank


@dataclass(frozen=True, slots=True)
class GraspPlan:
    """The moves to pick a target, from the ready pose to the lifted standoff.

    Attributes:
        T_grasp: gripper_link pose at the grasp (4x4, world frame).
        approach_ptp: ready -> standoff.
        approach_lin: standoff -> grasp.
        lift: grasp -> lifted.
        retreat: lifted -> lifted standoff.
        yaw: Heading the gripper points in [rad] (radial unless that collides,
            :meth:`Planner.plan_grasp`).
    """

    T_grasp: FloatArray
    approach_ptp: Move
    approach_lin: Move
    lift: Move
    retreat: Move
    yaw: float = 0.0
