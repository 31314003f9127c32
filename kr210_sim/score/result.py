"""What a cycle did and how it scored, and what was done to the cylinders between cycles: the
records a run's report is made of.

One cycle record (:meth:`CycleResult.to_dict`) serves ``run``, ``view`` and ``evaluate`` (an
evaluation's episode record is the cycle record with its episode number and seed in front). Every
field measured on the machine rather than simulated is named ``wall_*`` or ``cpu_*``, so "same
seed, same report apart from ``wall_*``/``cpu_*`` fields" is one rule
(:func:`kr210_sim.score.report.strip_wall`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from enum import StrEnum
from typing import Any

from kr210_sim.cell.spec import TargetSpec

__all__ = ["CycleResult", "Event", "EventKind", "TargetSample", "cycle_record"]


@dataclass(frozen=True, slots=True)
class TargetSample:
    """One cycle's target: where it spawns and what it is.

    Attributes:
        slot: Slot number (1-based).
        position: Spawn position of the centre [m].
        yaw: Spawn yaw [rad].
        spec: Size, mass and friction.
    """

    slot: int
    position: tuple[float, float, float]
    yaw: float
    spec: TargetSpec


@dataclass(frozen=True, slots=True)
class CycleResult:
    """What one cycle did and how it scored.

    Attributes:
        index: Cycle number (1-based).
        slot: Slot 1-9.
        success: True when the target rests in the bin.
        reason: Failure reason (an :class:`~kr210_sim.score.scoring.Outcome` value), None on
            success.
        detail: One sentence on what went wrong (empty on success).
        cycle_time: Simulated time from the first move to the end of the return move [s].
        max_tracking_error_deg: Largest |q_des - q| per joint over the cycle [deg].
        max_gripper_tracking_error_mm: The joint tracking error seen at the gripper: largest
            distance between gripper_link at the measured joints and at the commanded joints
            (forward kinematics of both) [mm]. Not an IK error: the plan's poses are exact.
        creep_mm: Largest displacement of the target relative to the gripper between the
            confirmed grip and the release [mm].
        grasp_attempts: Grasp attempts made.
        env_contact_ticks: Control ticks with robot-shelf or robot-bin contact.
        contact_pairs: Names of robot/environment geom pairs that touched.
        target: The target's spawn sample.
        target_final: The target's final centre [m].
        phase_times: Simulated duration of each phase [s].
        detours: Moves planned by OMPL around what blocked their direct move.
        wall_time: Wall-clock time of the cycle [s] (excluded from determinism checks).
        wall_planning_time: Wall-clock time spent planning the cycle's moves, collision checks
            and detours included [s] (excluded from determinism checks).
        cpu_planning_time: CPU time of that planning [s] (on a loaded machine the wall time
            also counts the waits for a core; excluded from determinism checks).
        moves: The cycle plan's arm moves: (phase, planner ("direct" or "ompl"), duration [s],
            lower bound of the duration at the joint velocity and acceleration limits [s]).
        perception: With ``run --perceive``, what the sensors saw scored against the truth
            (:meth:`kr210_sim.sim.perceived.PerceptionRecord.to_dict`); None (and no key in the
            record) without.
    """

    index: int
    slot: int
    success: bool
    reason: str | None
    detail: str
    cycle_time: float
    max_tracking_error_deg: tuple[float, ...]
    max_gripper_tracking_error_mm: float
    creep_mm: float
    grasp_attempts: int
    env_contact_ticks: int
    contact_pairs: tuple[tuple[str, str], ...]
    target: TargetSample
    target_final: tuple[float, float, float]
    phase_times: dict[str, float]
    detours: int
    wall_time: float
    wall_planning_time: float
    cpu_planning_time: float
    moves: tuple[tuple[str, str, float, float], ...] = ()
    perception: dict[str, Any] | None = None

    @property
    def bound_ratio(self) -> float:
        """The moves' total duration over their total lower bound (0 without moves)."""
        bound = sum(m[3] for m in self.moves)
        return sum(m[2] for m in self.moves) / bound if bound > 0 else 0.0

    def to_dict(self) -> dict[str, Any]:
        """The cycle record: a JSON-ready dictionary (see :func:`cycle_record`)."""
        return cycle_record(self)


def cycle_record(r: CycleResult) -> dict[str, Any]:
    """The record of one cycle, as ``run``'s report lists it and ``evaluate``'s episodes file
    holds it (after the episode number and seed): plain JSON types only."""
    d = asdict(r)
    d["max_tracking_error_deg"] = list(r.max_tracking_error_deg)
    d["contact_pairs"] = [list(p) for p in r.contact_pairs]
    d["target"] = {
        "slot": r.target.slot,
        "position": list(r.target.position),
        "yaw": r.target.yaw,
        "spec": asdict(r.target.spec),
    }
    d["target_final"] = list(r.target_final)
    d["moves"] = [{"phase": p, "planner": k, "duration": t, "bound": b} for p, k, t, b in r.moves]
    if r.perception is None:  # runs without --perceive keep the record they always had
        del d["perception"]
    return d


class EventKind(StrEnum):
    """Things the cell does to its cylinders between cycles."""

    BIN_EMPTIED = "bin_emptied"
    SHELF_CLEARED = "shelf_cleared"


@dataclass(frozen=True, slots=True)
class Event:
    """One thing done to the cylinders outside a pick-and-place cycle.

    Attributes:
        kind: What was done.
        before_cycle: The cycle it happened before (1-based, at most the cycles of the run).
        time: Simulated time [s].
        targets: Indices of the cylinders moved.
        detail: One sentence for the report and the video.
    """

    kind: EventKind
    before_cycle: int
    time: float
    targets: tuple[int, ...]
    detail: str

    def to_dict(self) -> dict[str, object]:
        """JSON-ready dictionary."""
        return {
            "kind": self.kind.value,
            "before_cycle": self.before_cycle,
            "time": round(self.time, 6),
            "targets": list(self.targets),
            "detail": self.detail,
        }
