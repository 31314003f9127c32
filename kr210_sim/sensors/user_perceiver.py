"""A user's perception in place of ours (``run --perceive --perception SPEC``).

:class:`UserPerception` is called as :func:`kr210_sim.perception.pipeline.perceive` is (the
looks so far, the label to pick, the bay, the recogniser, a seed) and returns the same
:class:`~kr210_sim.perception.pipeline.Percept`, so the
:class:`~kr210_sim.sensors.perceiver.Perceiver` takes its second look, plans and scores against
the truth as it does with ours. Each look is handed to the user's function once, in its sandbox
(:class:`~kr210_sim.sandbox.perception_sandbox.PerceptionSandbox`), with the contract of
:mod:`kr210_sim.sandbox.user_perception`; its answer is checked there. Whatever goes wrong in the
user's function (an exception, no answer in time, a crash, an answer not as the contract says)
is the look's problem, one line naming the function, and the target is then not seen: never a
pose.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from kr210_sim.cell.sensing_layout import pick_list_of
from kr210_sim.perception.camera import Observation
from kr210_sim.perception.cloud import BayBox
from kr210_sim.perception.kinds import Detection, Kind, Pose
from kr210_sim.perception.model import RecognitionModel
from kr210_sim.perception.pipeline import CONFIDENT, Look, Percept
from kr210_sim.plan.planner import Planner
from kr210_sim.sandbox.ik_sandbox import IkCrashed, IkTimeout
from kr210_sim.sandbox.ik_wire import Oversized
from kr210_sim.sandbox.perception_sandbox import PerceptionSandbox
from kr210_sim.sandbox.user_perception import Estimate, UnusableAnswer, read_answer, spec_name
from kr210_sim.sensors.perceiver import Perceiver
from kr210_sim.sensors.recognisers import cell_kinds
from kr210_sim.sim.perceived import PerceiverFactory

import mujoco  # isort: skip

FloatArray = npt.NDArray[np.float64]


def _frame(axis: FloatArray) -> FloatArray:
    """A rotation whose z column is ``axis`` (unit)."""
    z = axis / np.linalg.norm(axis)
    x = np.cross([0.0, 1.0, 0.0] if abs(z[0]) > 0.9 else [1.0, 0.0, 0.0], z)
    x /= np.linalg.norm(x)
    return np.column_stack((x, np.cross(z, x), z))


def look_items(
    obs: Observation, pick: str, pick_list: Sequence[str], bay: BayBox, kinds: Sequence[Kind]
) -> dict[str, Any]:
    """A look's small items as the user's function gets them (the contract's keys but the
    images)."""
    return {
        "sensor": obs.sensor,
        "time": float(obs.time),
        "K": np.asarray(obs.intrinsics.K, dtype=np.float64).tolist(),
        "T_base_camera": np.asarray(obs.T_base_camera, dtype=np.float64).tolist(),
        "pick": pick,
        "pick_list": list(pick_list),
        "kinds": {
            k.name: {"shape": k.shape, "size": list(k.size), "rgb": list(k.rgb)} for k in kinds
        },
        "bay": {"center": list(bay.centre), "yaw": bay.yaw, "half": list(bay.half)},
    }


class UserPerception:
    """A user's perception function, called as the pipeline's :func:`~kr210_sim.perception.
    pipeline.perceive` is.

    Args:
        sandbox: The user's function in its process (started).
        pick_list: The cell's pick list (what the function is told besides the cycle's pick).
        kinds: The cell's kinds (what the function is told of each).
    """

    def __init__(
        self, sandbox: PerceptionSandbox, pick_list: Sequence[str], kinds: Sequence[Kind]
    ) -> None:
        self.sandbox = sandbox
        self.pick_list = tuple(pick_list)
        self.kinds = tuple(kinds)
        #: How messages name the user's function (``file.py:function``).
        self.name = spec_name(sandbox.spec)

    def _call(self, obs: Observation, pick: str, bay: BayBox) -> tuple[Look, float]:
        """One look through the user's function: its detections, or the one-line problem."""
        items = look_items(obs, pick, self.pick_list, bay, self.kinds)
        cpu, problems, found = 0.0, [], []
        try:
            got = self.sandbox.look(items, {"rgb": obs.rgb, "depth": obs.depth})
            if isinstance(got, Oversized):
                raise UnusableAnswer(f"sent an answer of {got.size:,} bytes")
            c = got.get("cpu")
            cpu = float(c) if isinstance(c, float) and 0.0 <= c < 1e6 else 0.0
            found = read_answer(got)
        except (IkTimeout, IkCrashed, UnusableAnswer) as exc:
            problems.append(f"{self.name}: {exc}")
        except Exception as exc:  # what the user's function raised, by its type's name
            problems.append(f"{self.name} raised {type(exc).__name__}: {exc}")
        detections = tuple(self._detection(e) for e in found)
        empty = np.zeros((0, 3))
        look = Look(obs.sensor, detections, tuple(problems), {"user": cpu}, empty, np.zeros(0, int))
        return look, cpu

    def _detection(self, e: Estimate) -> Detection:
        """An estimate as the pipeline's detection (the kind's nominal size and shape)."""
        kind = next((k for k in self.kinds if k.name == e.label), None)
        shape, size = (kind.shape, kind.size) if kind is not None else ("cylinder", (0.0, 0.0))
        position, axis = np.array(e.position), np.array(e.axis)
        pose = Pose(position, axis, _frame(axis), size, 0.0)
        return Detection(e.label, e.confidence, shape, pose, 0, position, (), measured=False)

    def __call__(
        self,
        observations: Sequence[Observation],
        pick_label: str,
        bay: BayBox,
        model: RecognitionModel | None = None,
        seed: int = 0,
        done: Sequence[Look] = (),
    ) -> Percept:
        """The target among the user's answers to ``observations``: the entry labelled
        ``pick_label`` that is confident, then from the latest look, then the most confident.
        The first ``len(done)`` looks are not asked again (``done``: their answers, from the
        call before); ``cpu_time`` is the user's CPU time of the looks asked now. ``model`` and
        ``seed`` are not used (the function is told the cell's kinds, and has its own seed)."""
        new = [self._call(obs, pick_label, bay) for obs in observations[len(done) :]]
        cpu = sum(c for _, c in new)
        looks = (*done, *(look for look, _ in new))
        best: tuple[tuple[bool, int, float], Detection] | None = None
        for i, look in enumerate(looks):
            for d in look.detections:
                key = (d.confidence >= CONFIDENT, i, d.confidence)
                if d.label == pick_label and (best is None or key > best[0]):
                    best = (key, d)
        problems = [p for look in looks for p in look.problems]
        if best is None:
            said = ", ".join(
                f"{look.sensor}: " + (", ".join(d.label for d in look.detections) or "nothing")
                for look in looks
            )
            why = "; ".join(problems) if problems else f"not seen ({self.name} returned {said})"
            return Percept(pick_label, None, None, False, why, looks, cpu)
        target = best[1]
        confident = target.confidence >= CONFIDENT
        why = "" if confident else f"{self.name}: confidence {target.confidence:.2f} only"
        return Percept(pick_label, target, None, confident, why, looks, cpu)


def user_perceiver(sandbox: PerceptionSandbox) -> PerceiverFactory:
    """What makes the perceiver of ``run --perceive --perception SPEC``: ours, with the user's
    function (in ``sandbox``) in place of our pipeline, told the cell's pick list and kinds."""

    def make(model: mujoco.MjModel, planner: Planner) -> Perceiver:
        estimator = UserPerception(sandbox, pick_list_of(model), cell_kinds(model))
        return Perceiver(model, planner, estimator=estimator)

    return make
