"""Scoring one pick-and-place cycle from what was observed.

Scoring is a pure function of a :class:`CycleObservation` (filled in by the runner from the
simulation), so every failure reason can be tested on constructed situations.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

import numpy as np
import numpy.typing as npt

from kr210_sim.cell.layout import BinBox


class Outcome(StrEnum):
    """Result of a cycle: success or the reason it failed."""

    SUCCESS = "success"
    UNREACHABLE = "unreachable"
    COLLISION = "collision"
    KNOCKED_OVER = "knocked_over"
    GRASP_MISSED = "grasp_missed"
    DROPPED_IN_TRANSIT = "dropped_in_transit"
    MISSED_BIN = "missed_bin"
    #: The user's IK function (``--ik``) gave an unusable answer for a pose the plan needs.
    IK_FAILED = "ik_failed"
    #: No collision-free plan exists for a move of the cycle (scored before the arm moves).
    NO_PATH = "no_path"


#: Largest linear speed of a target counted as still [m/s].
REST_SPEED = 0.02
#: Largest angular speed of a target counted as still [rad/s] (a cylinder rocking on its rim or
#: rolling on its side can move its centre slowly while it turns fast).
REST_SPIN = 0.2
#: How long a target must stay still to count as at rest [s].
REST_WINDOW = 0.25


def is_still(speed: float, spin: float) -> bool:
    """Whether a target moving at ``speed`` [m/s] and turning at ``spin`` [rad/s] is still."""
    return speed < REST_SPEED and spin < REST_SPIN


def rest_window_ticks(timestep: float) -> int:
    """Consecutive still ticks of ``timestep`` [s] that make :data:`REST_WINDOW`."""
    return max(1, round(REST_WINDOW / timestep))


@dataclass(frozen=True, slots=True)
class CycleObservation:
    """What the runner saw during one cycle.

    Attributes:
        planned: False when no plan existed (a pose out of reach or past a joint limit).
        grasp_confirmed: True when the grip was confirmed after closing.
        held_until_release: True when the target stayed between the fingers until the gripper
            opened over the bin.
        released: True when the gripper opened over the bin.
        robot_env_contacts: Number of control ticks with a robot-shelf or robot-bin contact.
        target_position: Final target centre in [m], shape (3,).
        target_speed: Final linear speed of the target in [m/s].
        target_spin: Final angular speed of the target in [rad/s].
        rested_for: How long the target had been still (:func:`is_still`) at the end [s].
        target_toppled: True when the grip failed and the target was left tipped over (see
            :data:`TOPPLED_TILT_DEG`).
    """

    planned: bool
    grasp_confirmed: bool
    held_until_release: bool
    released: bool
    robot_env_contacts: int
    target_position: npt.NDArray[np.float64]
    target_speed: float
    target_spin: float
    rested_for: float
    target_toppled: bool = False


#: Tilt of a target's axis from the vertical beyond which it counts as knocked over [deg].
TOPPLED_TILT_DEG = 30.0


def in_bin(position: npt.ArrayLike, bin_box: BinBox, margin: float = 0.0) -> bool:
    """Whether a point lies inside the bin's walls and below its rim.

    Args:
        position: Point in [m], shape (3,).
        bin_box: The bin's inside (as the model holds it).
        margin: Extra clearance required from the inner walls in [m].
    """
    p = np.asarray(position, dtype=np.float64)
    cx, cy = bin_box.center
    hx, hy = bin_box.inner_half
    return bool(
        abs(p[0] - cx) < hx - margin
        and abs(p[1] - cy) < hy - margin
        and bin_box.floor_top < p[2] < bin_box.rim
    )


def at_rest_in_bin(position: npt.ArrayLike, rested_for: float, bin_box: BinBox) -> bool:
    """The target's part of a success: its centre inside the bin (:func:`in_bin`) and still
    (:func:`is_still`) for :data:`REST_WINDOW` [s] in a row.

    Args:
        position: Target centre [m], shape (3,).
        rested_for: How long it has been still [s].
        bin_box: The bin.
    """
    return in_bin(position, bin_box) and rested_for >= REST_WINDOW - 1e-9


def score(obs: CycleObservation, bin_box: BinBox) -> Outcome:
    """Score a cycle.

    A cycle succeeds when the target rests inside the bin (centre inside the walls, below the
    rim, still (:func:`is_still`) for :data:`REST_WINDOW`) after the gripper opened, with no
    robot contact with the shelf or the bin. Otherwise the first failure in this order is
    returned: unreachable, collision, knocked_over (no grip, target tipped over), grasp_missed,
    dropped_in_transit, missed_bin.

    Args:
        obs: What happened.
        bin_box: The bin's inside.

    Returns:
        The outcome.
    """
    if not obs.planned:
        return Outcome.UNREACHABLE
    if obs.robot_env_contacts > 0:
        return Outcome.COLLISION
    if not obs.grasp_confirmed:
        return Outcome.KNOCKED_OVER if obs.target_toppled else Outcome.GRASP_MISSED
    if not (obs.held_until_release and obs.released):
        return Outcome.DROPPED_IN_TRANSIT
    if not at_rest_in_bin(obs.target_position, obs.rested_for, bin_box):
        return Outcome.MISSED_BIN
    return Outcome.SUCCESS
