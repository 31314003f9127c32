"""The loop closed (``run --perceive``), on the runner's side: what the runner asks of a
perceiver (:class:`Perceiving`), how a cycle's perception is recorded (:class:`PerceptionRecord`)
and scored (:func:`rescore`), and a slot's bay read off the cell's layout (:func:`layout_bay`).

The perceiver itself renders the cell's sensors, so it lives downstream of the simulation
(:class:`kr210_sim.sensors.perceiver.Perceiver`); the runner is handed one
(``Runner(config, perceiver=Perceiver)``) and calls it once a cycle, before planning. Each
cycle's pick is then planned from what the sensors saw, not from the simulator's pose; the truth
only scores.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from kr210_sim.cell.layout import CellLayout
from kr210_sim.cell.spec import SHELF_BOARD_THICKNESS, SHELF_POST_WIDTH, TargetSpec
from kr210_sim.errors import ConfigError
from kr210_sim.perception.bays import SHELF_BACK_THICKNESS
from kr210_sim.perception.cloud import BayBox
from kr210_sim.perception.grasp import GripperEnvelope
from kr210_sim.plan.cycle import Move
from kr210_sim.plan.planner import Planner
from kr210_sim.score.result import TargetSample
from kr210_sim.score.scoring import Outcome, perceived_outcome
from kr210_sim.sim.cell import Cell

import mujoco  # isort: skip

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class PerceptionRecord:
    """What one cycle's perception saw, scored against the truth.

    Attributes:
        label: The kind the pick list asked for.
        seen: Whether a look found it.
        label_seen: The label of the detection picked from (None: not seen).
        right_object: Whether that detection lies on the cycle's target (its nearest object in
            the truth).
        position_error_mm: Distance from the estimated to the true centre [mm] (None: not seen).
        axis_error_deg: Angle between the estimated and the true axis [deg] (None: not seen).
        confidence: The recogniser's confidence in the detection (0: not seen).
        clusters: Clusters seen in each look.
        looks: Looks taken (1: the fixed sensor's; 2: the wrist camera's too).
        reason: Why the target was not seen or not trusted ("" when all was well).
        cpu_time_ms: CPU time of the pipeline, all looks [ms] (rendering not included).
        wall_look_ms: Wall-clock time of rendering the looks [ms].
    """

    label: str
    seen: bool
    label_seen: str | None
    right_object: bool
    position_error_mm: float | None
    axis_error_deg: float | None
    confidence: float
    clusters: tuple[int, ...]
    looks: int
    reason: str
    cpu_time_ms: float
    wall_look_ms: float

    def to_dict(self) -> dict[str, Any]:
        """The report's ``perception`` block (plain JSON types)."""
        return {
            "label": self.label,
            "seen": self.seen,
            "label_seen": self.label_seen,
            "right_object": self.right_object,
            "position_error_mm": self.position_error_mm,
            "axis_error_deg": self.axis_error_deg,
            "confidence": self.confidence,
            "clusters": list(self.clusters),
            "looks": self.looks,
            "reason": self.reason,
            "cpu_time_ms": self.cpu_time_ms,
            "wall_look_ms": self.wall_look_ms,
        }


def grasp_tolerance(radius: float, envelope: GripperEnvelope | None = None) -> float:
    """How far the target's centre may lie from the estimate and the open fingers still close
    on it [m]: half the open gap less the target's ``radius`` [m]."""
    env = envelope or GripperEnvelope()
    return max(env.open_gap / 2.0 - radius, 0.0)


def layout_bay(layout: CellLayout, slot: int) -> BayBox:
    """The inside of slot ``slot``'s bay, read off a compiled cell's layout (its slots and the
    shelf's outer volume), as :func:`~kr210_sim.perception.bays.bay_box` reads it off the cell
    file: from the board's top to the underside of the board above, between the posts, from
    the open front to the back panel.

    Raises:
        ValueError: When the shelf has no such slot.
    """
    n = len(layout.slots)
    if not 1 <= slot <= n:
        raise ValueError(f"slot {slot} is not on the shelf (slots 1-{n})")
    sb = layout.shelf
    local = (layout.slots - sb.center) @ sb.R  # each slot in the shelf frame
    tops = np.unique(np.round(local[:, 2], 6))
    columns = int(np.sum(np.isclose(local[:, 2], tops[0], atol=1e-6)))
    floor = float(local[slot - 1, 2])
    above = tops[tops > floor + 1e-6]
    ceiling = float(above[0] if len(above) else sb.half[2]) - SHELF_BOARD_THICKNESS
    front, back = -float(sb.half[0]), float(sb.half[0]) - SHELF_BACK_THICKNESS
    pitch = (2.0 * float(sb.half[1]) - SHELF_POST_WIDTH) / columns
    inside = np.array([(front + back) / 2.0, local[slot - 1, 1], (floor + ceiling) / 2.0])
    c = sb.center + sb.R @ inside
    half = ((back - front) / 2.0, (pitch - SHELF_POST_WIDTH) / 2.0, (ceiling - floor) / 2.0)
    yaw = math.atan2(float(sb.R[1, 0]), float(sb.R[0, 0]))
    return BayBox((float(c[0]), float(c[1]), float(c[2])), yaw, half)


class Perceiving(Protocol):
    """What the runner asks of a perceiver (:class:`kr210_sim.sensors.perceiver.Perceiver`)."""

    #: The estimate of the cycle's target centre [m] (None before a look found it).
    estimate: FloatArray | None
    #: The record of the last cycle's perception (None before a look).
    record: PerceptionRecord | None

    def look(
        self,
        cell: Cell,
        k: int,
        sample: TargetSample,
        label: str,
        q_cmd: FloatArray,
        track: Callable[[Move], None],
    ) -> TargetSpec:
        """Perceive cycle's target ``k`` (the pick list's ``label``) in ``sample``'s slot
        (never its pose): what the plan takes it to be (size as seen); its centre [m] is
        :attr:`estimate`. Moves of the arm (a second look) go through ``track``.

        Raises:
            NotSeenError: When no look found it.
        """
        ...


#: Makes a perceiver for a cell model and the runner's planner.
PerceiverFactory = Callable[[mujoco.MjModel, Planner], Perceiving]


def attach(
    perceive: bool, factory: PerceiverFactory | None, model: mujoco.MjModel, planner: Planner
) -> Perceiving | None:
    """The runner's perceiver: made by ``factory`` when ``perceive`` (None otherwise).

    Raises:
        ConfigError: When ``perceive`` is on and no factory is given.
    """
    if not perceive:
        return None
    if factory is None:
        raise ConfigError(
            "RunConfig(perceive=True) needs a perceiver: "
            "Runner(config, perceiver=kr210_sim.sensors.perceiver.Perceiver)"
        )
    return factory(model, planner)


def estimate_or(perceiver: Perceiving | None, truth: FloatArray) -> FloatArray:
    """The perceiver's estimate of the cycle's target centre [m], or ``truth`` [m] without
    one (a run told the simulator's pose)."""
    if perceiver is not None and perceiver.estimate is not None:
        return perceiver.estimate
    return truth


def rescore(
    perceiver: Perceiving | None, outcome: Outcome, detail: str, radius: float
) -> tuple[Outcome, str]:
    """The cycle's outcome with perception's part in it (:func:`perceived_outcome`); as it
    stands without a perceiver or when the target was not seen.

    Args:
        perceiver: The runner's perceiver (None: the truth was told).
        outcome: The outcome as scored without perception.
        detail: Its sentence.
        radius: The target's radius [m] (the grasp's tolerance).
    """
    r = None if perceiver is None else perceiver.record
    if r is None or not r.seen:
        return outcome, detail
    error = (r.position_error_mm or 0.0) / 1000.0
    tol = grasp_tolerance(radius)
    new = perceived_outcome(outcome, r.right_object, error, tol)
    if new is outcome:
        return outcome, detail
    if new is Outcome.WRONG_OBJECT:
        why = f"perceived the target {r.label} on another object ({r.label_seen} seen)"
    else:
        why = (
            f"the estimate was {r.position_error_mm:.1f} mm off the target's centre "
            f"(the grasp tolerates {tol * 1000:.1f} mm)"
        )
    return new, f"{why}; {detail}" if detail else why


def report(perceiver: Perceiving | None) -> dict[str, Any] | None:
    """The cycle record's ``perception`` block (None without a perceiver or a look)."""
    r = None if perceiver is None else perceiver.record
    return None if r is None else r.to_dict()


def shown(perceiver: Perceiving | None) -> dict[str, object]:
    """What the video's overlay shows of the cycle's look: ``seen`` (the label recognised, its
    confidence, whether it was the target) and ``seen_at`` (the estimated centre [m]); empty
    without a perceiver or before the cycle's look ends."""
    r = None if perceiver is None else perceiver.record
    if r is None:
        return {}
    if not r.seen or perceiver is None or perceiver.estimate is None:
        return {"seen": f"{r.label}: not seen", "seen_at": None}
    on = "on the target" if r.right_object else "NOT the target"
    text = f"seen {r.label_seen} ({r.confidence:.0%}, {on})"
    return {"seen": text, "seen_at": tuple(float(c) for c in perceiver.estimate)}


class SeenStatus(Mapping[str, object]):
    """The runner's live status with what its perceiver saw added (``seen``, ``seen_at``:
    :func:`shown`), read afresh at every key: what a video's frame recorder reads. Nothing is
    shown while a cycle's target spawns (the last look was the cycle before's).

    Args:
        status: The runner's status.
        perceiver: The runner's perceiver.
    """

    KEYS = ("seen", "seen_at")

    def __init__(self, status: Mapping[str, object], perceiver: Perceiving) -> None:
        self.status, self.perceiver = status, perceiver

    def _shown(self) -> dict[str, object]:
        return {} if self.status.get("phase") == "spawn" else shown(self.perceiver)

    def __getitem__(self, key: str) -> object:
        if key in self.KEYS:
            return self._shown()[key]
        return self.status[key]

    def __iter__(self) -> Iterator[str]:
        yield from self.status
        yield from self._shown()

    def __len__(self) -> int:
        return len(self.status) + len(self._shown())


def with_seen(status: Mapping[str, object], perceiver: Perceiving | None) -> Mapping[str, object]:
    """``status`` with what ``perceiver`` saw (:class:`SeenStatus`); as it is without one."""
    return status if perceiver is None else SeenStatus(status, perceiver)
