"""Scoring one pick-and-place cycle from what was observed.

Scoring is a pure function of a :class:`CycleObservation` (filled in by the runner from the
simulation), so every failure reason can be tested on constructed situations.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

import numpy as np
import numpy.typing as npt

from kr210_sim.config import BinSpec


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


#: Largest linear speed of a target counted as resting, in [m/s] (a cylinder lying on its side
#: may still roll slowly across the bin floor).
REST_SPEED = 0.05


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
    target_toppled: bool = False


#: Tilt of a target's axis from the vertical beyond which it counts as knocked over [deg].
TOPPLED_TILT_DEG = 30.0


def in_bin(position: npt.ArrayLike, bin_spec: BinSpec, margin: float = 0.0) -> bool:
    """Whether a point lies inside the bin's walls and below its rim.

    Args:
        position: Point in [m], shape (3,).
        bin_spec: The bin.
        margin: Extra clearance required from the inner walls in [m].
    """
    p = np.asarray(position, dtype=np.float64)
    cx, cy = bin_spec.center_xy
    half = bin_spec.inner_half - margin
    return bool(
        abs(p[0] - cx) < half
        and abs(p[1] - cy) < half
        and bin_spec.floor_top < p[2] < bin_spec.height
    )


def score(obs: CycleObservation, bin_spec: BinSpec) -> Outcome:
    """Score a cycle.

    A cycle succeeds when the target rests inside the bin (centre inside the walls, below the
    rim, speed below :data:`REST_SPEED`) after the gripper opened, with no robot contact with
    the shelf or the bin. Otherwise the first failure in this order is returned: unreachable,
    collision, knocked_over (no grip, target tipped over), grasp_missed, dropped_in_transit,
    missed_bin.

    Args:
        obs: What happened.
        bin_spec: The bin.

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
    if not in_bin(obs.target_position, bin_spec) or obs.target_speed > REST_SPEED:
        return Outcome.MISSED_BIN
    return Outcome.SUCCESS
