"""Scoring one pick-and-place cycle from what was observed: the outcome and its detail.

This module is the one owner of the rule for success. Scoring is a pure function of a
:class:`CycleObservation` (filled in by the runner from the simulation), so every failure reason
can be tested on constructed situations; the Gymnasium environment judges its episodes with the
same function (:func:`episode_success`), and the runner's settle wait ends by it
(:func:`outcome_decided`).

The end of a cycle: the target is in the bin for good when its centre is inside the walls and
below the rim and the kinetic energy of every cylinder in play, all given to it, could not lift
its centre to the rim (:func:`contained`: ``z + E / (m g) < rim``): it cannot leave, whether it
is still or not. A centre inside the bin that could still rise over the rim when the settle wait
ends is ``not_settled``; only a centre outside the bin's inside is ``missed_bin``: outside its
walls, or inside them but at or above the rim (a cylinder standing on the floor of a bin less
deep than half its length; cell files refuse such a bin, :mod:`kr210_sim.cell.toml`).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

import numpy as np
import numpy.typing as npt

from kr210_sim.cell.layout import BinBox
from kr210_sim.errors import IkFailedError, NoPathError, NotSeenError

__all__ = [
    "GRAVITY",
    "REST_SPEED",
    "REST_SPIN",
    "REST_WINDOW",
    "TOPPLED_TILT_DEG",
    "CycleObservation",
    "Outcome",
    "RestCounter",
    "bin_region",
    "contained",
    "describe",
    "episode_success",
    "in_bin",
    "in_region",
    "is_still",
    "judge",
    "outcome_decided",
    "perceived_outcome",
    "plan_failure",
    "rest_window_ticks",
    "rise",
    "score",
]

FloatArray = npt.NDArray[np.float64]


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
    #: The target's centre is in the bin, but when the settle wait ended the cylinders in play
    #: still moved fast enough to lift it over the rim (see :func:`contained`).
    NOT_SETTLED = "not_settled"
    #: ``--perceive``: no look (the fixed sensor's, then the wrist camera's) found the target.
    NOT_SEEN = "not_seen"
    #: ``--perceive``: the cycle failed, and the object perceived as the target was another.
    WRONG_OBJECT = "wrong_object"
    #: ``--perceive``: the grasp missed, and the estimate was off the target's centre by more
    #: than the grasp tolerates (:func:`perceived_outcome`).
    GRASP_MISSED_ESTIMATE_OFF = "grasp_missed_estimate_off"


#: Largest linear speed of a target counted as still [m/s].
REST_SPEED = 0.02
#: Largest angular speed of a target counted as still [rad/s] (a cylinder rocking on its rim or
#: rolling on its side can move its centre slowly while it turns fast).
REST_SPIN = 0.2
#: How long a target must stay still to count as at rest [s].
REST_WINDOW = 0.25
#: Tilt of a target's axis from the vertical beyond which it counts as knocked over [deg].
TOPPLED_TILT_DEG = 30.0
#: Gravitational acceleration [m/s^2] (the scene's ``gravity``, MuJoCo's default).
GRAVITY = 9.81


def is_still(speed: float, spin: float) -> bool:
    """Whether a target moving at ``speed`` [m/s] and turning at ``spin`` [rad/s] is still."""
    return speed < REST_SPEED and spin < REST_SPIN


def rest_window_ticks(timestep: float) -> int:
    """Consecutive still ticks of ``timestep`` [s] that make :data:`REST_WINDOW`."""
    return max(1, round(REST_WINDOW / timestep))


class RestCounter:
    """Counts how long a target has been still (:func:`is_still`), one physics tick at a time.

    The runner's settle wait and the Gymnasium environment's steps both feed it every tick.

    Args:
        timestep: The physics timestep [s].
    """

    def __init__(self, timestep: float) -> None:
        self.timestep = float(timestep)
        self.window = rest_window_ticks(self.timestep)
        self.ticks = 0

    def update(self, speed: float, spin: float) -> bool:
        """Count one tick of a target moving at ``speed`` [m/s] and turning at ``spin``
        [rad/s]; True once it has been still for :data:`REST_WINDOW`."""
        self.ticks = self.ticks + 1 if is_still(speed, spin) else 0
        return self.ticks >= self.window

    def reset(self) -> None:
        """Start counting again."""
        self.ticks = 0

    @property
    def rested_for(self) -> float:
        """How long the target has been still [s]."""
        return self.ticks * self.timestep


@dataclass(frozen=True, slots=True)
class CycleObservation:
    """What the runner saw during one cycle.

    Attributes:
        grasp_confirmed: True when the grip was confirmed after closing.
        held_until_release: True when the target stayed between the fingers until the gripper
            opened over the bin.
        released: True when the gripper opened over the bin.
        robot_env_contacts: Number of control ticks with a robot-shelf or robot-bin contact.
        target_position: Final target centre in [m], shape (3,).
        target_speed: Final linear speed of the target in [m/s].
        target_spin: Final angular speed of the target in [rad/s].
        rested_for: How long the target had been still (:func:`is_still`) at the end [s].
        target_mass: The target's mass [kg].
        energy: Kinetic energy of every cylinder in play at the end, the target's included [J]
            (what could still be given to the target, :func:`contained`).
        plan_failure: Why no plan existed (:attr:`Outcome.UNREACHABLE`, ``IK_FAILED`` or
            ``NO_PATH``, see :func:`plan_failure`), None when the cycle was planned.
        plan_message: The planner's sentence on that failure.
        target_tilt_deg: Angle of the target's axis from the vertical when the grip was given
            up [deg] (0 when it was confirmed).
        grasp_attempts: Grasp attempts made.
        finger_gap: Finger gap after the last unconfirmed grip [m].
        target_radius: The target's radius [m].
        slot: The slot the target was picked from.
        contact_pairs: Names of robot/environment geom pairs that touched.
    """

    grasp_confirmed: bool
    held_until_release: bool
    released: bool
    robot_env_contacts: int
    target_position: FloatArray
    target_speed: float
    target_spin: float
    rested_for: float
    target_mass: float = 0.05
    energy: float = 0.0
    plan_failure: Outcome | None = None
    plan_message: str = ""
    target_tilt_deg: float = 0.0
    grasp_attempts: int = 0
    finger_gap: float = 0.0
    target_radius: float = 0.0
    slot: int = 0
    contact_pairs: tuple[tuple[str, str], ...] = ()


def plan_failure(exc: Exception) -> Outcome:
    """The outcome of a cycle whose planning raised ``exc``: ``ik_failed`` for the user's IK,
    ``no_path`` when every plan collides, ``unreachable`` otherwise."""
    if isinstance(exc, IkFailedError):
        return Outcome.IK_FAILED
    if isinstance(exc, NoPathError):
        return Outcome.NO_PATH
    if isinstance(exc, NotSeenError):
        return Outcome.NOT_SEEN
    return Outcome.UNREACHABLE


def perceived_outcome(
    outcome: Outcome, right_object: bool, error: float, tolerance: float
) -> Outcome:
    """A perceived cycle's outcome (``run --perceive``), scored against the truth: a failure
    after perceiving another object as the target is ``wrong_object``; a missed grasp whose
    estimate was off the target's centre by more than the grasp's ``tolerance`` [m] (``error``
    [m]) is ``grasp_missed_estimate_off``; anything else stands."""
    if outcome in (Outcome.SUCCESS, Outcome.NOT_SEEN):
        return outcome
    if not right_object:
        return Outcome.WRONG_OBJECT
    if outcome is Outcome.GRASP_MISSED and error > tolerance:
        return Outcome.GRASP_MISSED_ESTIMATE_OFF
    return outcome


def bin_region(bin_box: BinBox) -> tuple[FloatArray, FloatArray]:
    """The bin's inside as a box: its centre and half extents [m], each shape (3,)."""
    centre = np.array([*bin_box.center, (bin_box.floor_top + bin_box.rim) / 2.0])
    half = np.array([*bin_box.inner_half, (bin_box.rim - bin_box.floor_top) / 2.0])
    return centre, half


def in_region(
    points: npt.ArrayLike, centre: npt.ArrayLike, half: npt.ArrayLike
) -> npt.NDArray[np.bool_]:
    """Whether each point lies strictly inside the box ``centre`` +- ``half``.

    Args:
        points: Shape (..., 3) [m].
        centre: Box centres, shape (3,) or broadcastable to ``points`` [m].
        half: Half extents, shape (3,) [m].
    """
    p = np.asarray(points, dtype=np.float64)
    return np.all(np.abs(p - np.asarray(centre)) < np.asarray(half), axis=-1)


def in_bin(position: npt.ArrayLike, bin_box: BinBox, margin: float = 0.0) -> bool:
    """Whether a point lies inside the bin's walls and below its rim.

    Args:
        position: Point in [m], shape (3,).
        bin_box: The bin's inside (as the model holds it).
        margin: Extra clearance required from the inner walls in [m].
    """
    p = np.asarray(position, dtype=np.float64)
    return _within_walls(p, bin_box, margin) and bool(bin_box.floor_top < p[2] < bin_box.rim)


def _within_walls(p: FloatArray, bin_box: BinBox, margin: float = 0.0) -> bool:
    """Whether the point ``p`` [m] lies inside the bin's walls, whatever its height."""
    cx, cy = bin_box.center
    hx, hy = bin_box.inner_half
    return bool(abs(p[0] - cx) < hx - margin and abs(p[1] - cy) < hy - margin)


def rise(energy: npt.ArrayLike, mass: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """How high ``energy`` [J], all turned into height, could lift a body of ``mass`` [kg] [m]."""
    return np.asarray(energy, dtype=np.float64) / (np.asarray(mass, dtype=np.float64) * GRAVITY)


def contained(
    position: npt.ArrayLike, lift: npt.ArrayLike, centre: npt.ArrayLike, half: npt.ArrayLike
) -> npt.NDArray[np.bool_]:
    """Whether a target is in the region for good: its centre inside the region's walls and
    below its top, and ``lift`` [m] (:func:`rise` of the energy that could be given to it) not
    enough to bring the centre up to the top. To leave over a wall its centre has to pass above
    the wall's top edge, so with no more energy than that it cannot leave, moving or not.
    Vectorised over leading axes.

    Args:
        position: Target centres, shape (..., 3) [m].
        lift: Height the energy could lift each target [m].
        centre: Region centres, shape (3,) or (..., 3) [m].
        half: Region half extents, shape (3,) [m].
    """
    p = np.asarray(position, dtype=np.float64)
    top = np.asarray(centre, dtype=np.float64)[..., 2] + np.asarray(half, dtype=np.float64)[2]
    return in_region(p, centre, half) & (p[..., 2] + np.asarray(lift) < top)


def score(obs: CycleObservation, bin_box: BinBox) -> Outcome:
    """Score a cycle.

    A cycle succeeds when, after the gripper opened over the bin, the target is in the bin for
    good (:func:`contained`: centre inside the walls and below the rim, and the kinetic energy of
    every cylinder in play could not lift it to the rim), with no robot contact with the cell.
    Otherwise the first failure in this order is returned: the plan's failure (unreachable,
    ik_failed, no_path), collision, knocked_over (no grip, target tipped over), grasp_missed,
    dropped_in_transit, missed_bin (centre outside the bin's walls, or at or above its rim),
    not_settled (centre in the bin, but the energy in play could still lift it over the rim).

    Args:
        obs: What happened.
        bin_box: The bin's inside.

    Returns:
        The outcome.
    """
    if obs.plan_failure is not None:
        return obs.plan_failure
    if obs.robot_env_contacts > 0:
        return Outcome.COLLISION
    if not obs.grasp_confirmed:
        toppled = obs.target_tilt_deg > TOPPLED_TILT_DEG
        return Outcome.KNOCKED_OVER if toppled else Outcome.GRASP_MISSED
    if not (obs.held_until_release and obs.released):
        return Outcome.DROPPED_IN_TRANSIT
    if not in_bin(obs.target_position, bin_box):
        return Outcome.MISSED_BIN
    if not contained(obs.target_position, rise(obs.energy, obs.target_mass), *bin_region(bin_box)):
        return Outcome.NOT_SETTLED
    return Outcome.SUCCESS


def outcome_decided(
    position: npt.ArrayLike, rested_for: float, energy: float, mass: float, bin_box: BinBox
) -> bool:
    """Whether a cycle's outcome can no longer change while the cell waits: the target is in
    the bin for good (:func:`contained`), or it has been still for :data:`REST_WINDOW` wherever
    it lies. The runner's settle wait ends on the first tick this holds.

    Args:
        position: The target's centre [m], shape (3,).
        rested_for: How long it has been still [s].
        energy: Kinetic energy of every cylinder in play [J].
        mass: The target's mass [kg].
        bin_box: The bin.
    """
    if rested_for >= REST_WINDOW - 1e-9:
        return True
    return bool(contained(position, rise(energy, mass), *bin_region(bin_box)))


def describe(outcome: Outcome, obs: CycleObservation, bin_box: BinBox) -> str:
    """One sentence on why a cycle failed, from what was measured (empty on success)."""
    p = np.round(obs.target_position, 3).tolist()
    grip = (
        f"grip not confirmed on attempt {obs.grasp_attempts}: finger gap "
        f"{obs.finger_gap * 1000:.1f} mm, target diameter {2000 * obs.target_radius:.1f} mm"
    )
    if outcome is Outcome.SUCCESS:
        return ""
    if obs.plan_failure is not None:
        return obs.plan_message or outcome.value
    if outcome is Outcome.COLLISION:
        pairs = ", ".join(f"{a}/{b}" for a, b in sorted(obs.contact_pairs)[:3])
        return f"robot touched the cell for {obs.robot_env_contacts} ticks ({pairs})"
    if outcome is Outcome.KNOCKED_OVER:
        return (
            f"the target was knocked over in slot {obs.slot} (axis {obs.target_tilt_deg:.0f} deg "
            f"from vertical) on attempt {obs.grasp_attempts}; {grip}"
        )
    if outcome is Outcome.GRASP_MISSED:
        return grip
    if outcome is Outcome.DROPPED_IN_TRANSIT:
        return f"the target left the fingers before the release; it lies at {p}"
    if outcome is Outcome.MISSED_BIN:
        moving = (
            f"moving at {obs.target_speed:.3f} m/s and {obs.target_spin:.2f} rad/s (still for "
            f"{obs.rested_for:.2f} s)"
        )
        position = np.asarray(obs.target_position, dtype=np.float64)
        if _within_walls(position, bin_box) and position[2] >= bin_box.rim:
            return (
                f"the target's centre ended above the bin's rim, inside its walls, at {p} (rim "
                f"at z = {bin_box.rim:.3f} m; it counts only with its centre below the rim), "
                f"{moving}"
            )
        return f"the target ended outside the bin at {p}, {moving}"
    if outcome is Outcome.NOT_SETTLED:
        lift = float(rise(obs.energy, obs.target_mass))
        return (
            f"the target is inside the bin at {p}, still moving at {obs.target_speed:.3f} m/s and "
            f"{obs.target_spin:.2f} rad/s when the settle wait ended: the cylinders in play "
            f"carry {1000 * obs.energy:.1f} mJ, enough to lift it {1000 * lift:.0f} mm, and the "
            f"rim is {1000 * (bin_box.rim - p[2]):.0f} mm above its centre"
        )
    return outcome.value


def judge(obs: CycleObservation, bin_box: BinBox) -> tuple[Outcome, str]:
    """The outcome of a cycle (:func:`score`) and its detail sentence (:func:`describe`)."""
    outcome = score(obs, bin_box)
    return outcome, describe(outcome, obs, bin_box)


def episode_success(
    position: npt.ArrayLike,
    lift: npt.ArrayLike,
    released: npt.ArrayLike,
    robot_env_contacts: npt.ArrayLike,
    centre: npt.ArrayLike,
    half: npt.ArrayLike,
) -> npt.NDArray[np.bool_]:
    """Whether a Gymnasium episode has succeeded, by the rule :func:`score` applies to a cycle.

    The episode's policy, not a plan, moves the arm, so the plan and grasp stages do not apply;
    the rest does, as in :func:`score`: no robot contact with the cell during the episode, the
    fingers let go, and the target in the goal region for good (:func:`contained`). Vectorised
    over leading axes (a batch of relabelled goals).

    Args:
        position: Target centres, shape (..., 3) [m].
        lift: Height the kinetic energy in play could lift each target [m] (:func:`rise`).
        released: Whether the fingers no longer touch the target.
        robot_env_contacts: Ticks with a robot-cell contact so far.
        centre: Goal region centres, shape (3,) or (..., 3) [m] (:func:`bin_region` for the bin).
        half: Half extents of the goal region, shape (3,) [m].
    """
    clean = np.asarray(robot_env_contacts) == 0
    let_go = np.asarray(released, dtype=bool)
    return clean & let_go & contained(position, lift, centre, half)
