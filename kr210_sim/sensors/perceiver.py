"""The perceiver of ``run --perceive`` (:class:`Perceiver`): each cycle's pick is planned from
what the cell's sensors saw, not from the simulator's pose; the truth only scores.

Per cycle (:meth:`Perceiver.look`): the fixed shelf sensor looks at the slot's bay and the
pipeline (:func:`~kr210_sim.perception.pipeline.perceive`) estimates the pick kind's pose. When
the target is not seen, or not with confidence, or a cylinder's radius was not measured (a far
look's is not: :attr:`~kr210_sim.perception.pipeline.Percept.precise`), the arm carries the wrist
camera to a second look (:func:`~kr210_sim.sensors.looks.wrist_look_q`, at the estimate or,
unseen, at the slot) and the pipeline takes both looks. Still unseen:
:class:`~kr210_sim.errors.NotSeenError` (scored ``not_seen`` before the pick). After the look the
truth (:func:`~kr210_sim.sensors.shelf_truth`) is read, for the report only: whether the
estimate lies on the target, and how far off it is.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from kr210_sim.cell.layout import CellLayout
from kr210_sim.cell.spec import TargetSpec
from kr210_sim.errors import ConfigError, NotSeenError, PlanningError, UnreachablePoseError
from kr210_sim.perception.camera import Observation
from kr210_sim.perception.model import RecognitionModel
from kr210_sim.perception.pipeline import Percept, perceive
from kr210_sim.plan.cycle import Move
from kr210_sim.plan.planner import Planner
from kr210_sim.score.result import TargetSample
from kr210_sim.sensors.looks import wrist_look_q
from kr210_sim.sensors.recognisers import cell_kinds, recogniser_for
from kr210_sim.sensors.render import SensorRig
from kr210_sim.sensors.truth import shelf_truth
from kr210_sim.sim.cell import Cell
from kr210_sim.sim.perceived import PerceptionRecord, layout_bay

import mujoco  # isort: skip

FloatArray = npt.NDArray[np.float64]

#: The phase of the move that carries the wrist camera to its look.
LOOK_PHASE = "look"


def _axis_error_deg(estimated: FloatArray, true: FloatArray) -> float:
    """Angle between two axes, either sign [deg]."""
    c = abs(float(np.dot(estimated, true))) / max(
        float(np.linalg.norm(estimated) * np.linalg.norm(true)), 1e-12
    )
    return math.degrees(math.acos(min(c, 1.0)))


class Perceiver:
    """Looks at each cycle's bay and estimates the target's pose for the runner.

    Args:
        model: The cell model (with sensors: a fixed one looking at the shelf, and optionally
            one on the gripper).
        planner: Plans the move to the wrist look.
        recogniser: The recognition model (default, with our pipeline: the cell's,
            :func:`~kr210_sim.sensors.recognisers.recogniser_for`; none with a user's
            function, which is told the cell's kinds).
        estimator: What makes a percept of the looks, called as
            :func:`~kr210_sim.perception.pipeline.perceive` (default: that, our pipeline; a
            user's function: :class:`~kr210_sim.sensors.user_perceiver.UserPerception`); with
            the second look it is given the first's analysis (``done``), not to redo it.

    Raises:
        ConfigError: When the cell has no sensors, or no fixed one.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        planner: Planner,
        recogniser: RecognitionModel | None = None,
        estimator: Callable[..., Percept] | None = None,
    ) -> None:
        self.model, self.planner = model, planner
        self.estimator: Callable[..., Percept] = estimator or perceive
        #: The cell's kinds, by label.
        self.kinds = {k.name: k for k in cell_kinds(model)}
        self.layout = CellLayout.from_model(model)
        self.rig = SensorRig(model)
        fixed = [s.name for s in self.rig.sensors.values() if s.mount == "world"]
        wrist = [s.name for s in self.rig.sensors.values() if s.mount == "gripper"]
        if not fixed:
            raise ConfigError("--perceive needs a fixed sensor looking at the shelf in the cell")
        self.fixed, self.wrist = fixed[0], (wrist[0] if wrist else None)
        if recogniser is None and estimator is None:
            recogniser = recogniser_for(model)
        self.recogniser = recogniser
        if recogniser is not None:
            recogniser.probabilities(recogniser.X[:1])  # fit the SVM now, not in a cycle
        self.rig.warm(mujoco.MjData(model))  # and make the renderers now
        #: The estimate of the cycle's target centre [m] (None before a look found it).
        self.estimate: FloatArray | None = None
        #: The record of the last cycle's perception.
        self.record: PerceptionRecord | None = None
        #: The last cycle's observations, in order (what ``perceive`` draws).
        self.observations: tuple[Observation, ...] = ()
        #: What the pipeline made of them.
        self.percept: Percept | None = None

    def look(
        self,
        cell: Cell,
        k: int,
        sample: TargetSample,
        label: str,
        q_cmd: FloatArray,
        track: Callable[[Move], None],
        seed: int = 0,
    ) -> TargetSpec:
        """Perceive cycle's target ``k`` (the pick list's ``label``) in ``slot``'s bay.

        Args:
            cell: The simulated cell (its state: the sensors render it).
            k: The target's index in the pool (for the truth's score only).
            sample: The cycle's target as drawn: its slot (the bay looked at) and radius (the
                wrist look's standoff) only; never its pose.
            label: The kind to pick.
            q_cmd: Where the arm is commanded now [rad].
            track: Runs a move of the arm (the runner's tracking, recorded).
            seed: Seeds the pipeline's RANSAC.

        Returns:
            What the plan takes the target to be: the fitted radius and length (the kind's
            where the look could not measure them), the cell's nominal mass and friction. Its
            estimated centre [m] is :attr:`estimate`.

        Raises:
            NotSeenError: When no look found it (:attr:`record` says what was seen).
        """
        self.estimate, self.record = None, None
        self.observations, self.percept = (), None
        slot, kind = sample.slot, self.kinds[label]
        radius = kind.size[0]  # the kind's: the wrist look's standoff
        box = layout_bay(self.layout, slot)
        wall = 0.0
        t0 = time.perf_counter()
        looks: list[Observation] = [self.rig.look(cell.data, self.fixed)]
        wall += time.perf_counter() - t0
        p = self.estimator(looks, label, box, self.recogniser, seed)
        cpu = p.cpu_time
        if not (p.seen and p.confident and p.precise) and self.wrist is not None:
            where = (
                p.target.pose.position
                if p.target is not None and p.target.pose is not None
                else self._slot_centre(slot, label)
            )
            if self._carry_wrist(where, radius, q_cmd, track):
                t0 = time.perf_counter()
                looks.append(self.rig.look(cell.data, self.wrist))
                wall += time.perf_counter() - t0
                p = self.estimator(looks, label, box, self.recogniser, seed, done=p.looks)
                cpu += p.cpu_time
        self.record = self._score(cell, k, label, p, len(looks), cpu, wall)
        self.observations, self.percept = tuple(looks), p
        if p.target is None or p.target.pose is None:
            raise NotSeenError(f"{label} not seen in slot {slot}: {p.reason}")
        pose = p.target.pose
        self.estimate = np.asarray(pose.position, dtype=np.float64).copy()
        size = pose.size if p.target.shape == "cylinder" else kind.size
        return dataclasses.replace(self.layout.target, radius=size[0], length=size[1])

    def _slot_centre(self, slot: int, label: str) -> FloatArray:
        """Where a ``label`` standing at ``slot``'s centre would have its centre [m] (the
        layout's, not the truth's)."""
        centre = np.asarray(self.layout.slots[slot - 1], dtype=np.float64).copy()
        centre[2] += self.kinds[label].height / 2.0
        return centre

    def _carry_wrist(
        self, where: FloatArray, radius: float, q_cmd: FloatArray, track: Callable[[Move], None]
    ) -> bool:
        """Move the arm to the wrist look at ``where`` [m]; False when it cannot be reached
        or planned clear (the arm stays)."""
        try:
            q = wrist_look_q(self.planner.kinematics, self.planner.robot, where, q_cmd, radius)
            move = self.planner.checked(self.planner.ptp(LOOK_PHASE, q_cmd, q))
        except (UnreachablePoseError, PlanningError):
            return False
        track(move)
        return True

    def _score(
        self, cell: Cell, k: int, label: str, p: Percept, looks: int, cpu: float, wall: float
    ) -> PerceptionRecord:
        """The percept against the truth (read now, for the report only)."""
        clusters = tuple(len(look.detections) for look in p.looks)
        if p.target is None or p.target.pose is None:
            return PerceptionRecord(
                label, False, None, False, None, None, 0.0, clusters, looks, p.reason,
                round(cpu * 1000.0, 3), round(wall * 1000.0, 3),
            )  # fmt: skip
        mujoco.mj_forward(self.model, cell.data)
        truth = shelf_truth(self.model, cell.data, self.layout)
        body = int(cell.handles.target_bodies[k])
        est = np.asarray(p.target.pose.position, dtype=np.float64)
        mine = next((o for o in truth if o.body == body), None)
        nearest = min(truth, key=lambda o: float(np.linalg.norm(o.position - est)), default=None)
        right = mine is not None and nearest is mine
        err = axis = None
        if mine is not None:
            err = round(float(np.linalg.norm(est - mine.position)) * 1000.0, 3)
            axis = round(_axis_error_deg(np.asarray(p.target.pose.axis), mine.R[:, 2]), 3)
        return PerceptionRecord(
            label, True, p.target.label, right, err, axis, round(p.target.confidence, 4),
            clusters, looks, p.reason, round(cpu * 1000.0, 3), round(wall * 1000.0, 3),
        )  # fmt: skip

    def close(self) -> None:
        """Free the sensors' renderers."""
        self.rig.close()
