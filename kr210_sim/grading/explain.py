"""One source of diagnoses for every command: ``grade``, ``ik-check`` and ``run --ik`` name a
student's mistakes with :func:`~kr210_sim.grading.diagnose.diagnose`, from the answers each saw.

* ``grade`` and ``ik-check`` diagnose their ik-check records;
* ``run --ik`` diagnoses the answers the run asked for (:class:`Watched` keeps them as the
  planner gets them, every pose of every move, :func:`Watched.records` judges them as ik-check
  judges its cases) with the run's failed cycles;
* every command gets the notes a ROS-form server's process sent
  (:func:`~kr210_sim.grading.finding.notes_of`: what Python 2 semantics changed, and the
  compatibility the libraries needed), and prints the findings alike
  (:func:`~kr210_sim.grading.finding.finding_lines`).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from kr210_sim.grading.diagnose import diagnose
from kr210_sim.grading.finding import Finding, finding_lines, notes_of
from kr210_sim.grading.ikcheck import Case, case_record
from kr210_sim.robot.kinematics import Kinematics
from kr210_sim.sandbox.ik_guard import assess
from kr210_sim.sandbox.user_ik import UserIk

FloatArray = npt.NDArray[np.float64]

#: Most answers of a run kept for its diagnosis (a 10-cycle run asks for ~2,000).
MAX_KEPT = 50_000


class Watched:
    """A user's IK whose every answer is kept as it is given (see the module doc).

    Args:
        ik: The user's IK.
        limit: Most answers kept (the first ones).
    """

    def __init__(self, ik: UserIk, limit: int = MAX_KEPT) -> None:
        self.ik = ik
        self.limit = limit
        #: ``(T, q_ref, answer or exception, time [s])`` of each answer, in order.
        self.asked: list[tuple[FloatArray, FloatArray, Any, float]] = []

    def _keep(self, T: Any, q_ref: Any, raw: Any, dt: float) -> None:
        if len(self.asked) < self.limit:
            self.asked.append(
                (np.array(T, dtype=np.float64), np.array(q_ref, dtype=np.float64), raw, dt)
            )

    def _call(self, T: FloatArray, q_ref: FloatArray) -> Any:
        t = time.perf_counter()
        try:
            out = self.ik.function(T, q_ref)
        except Exception as exc:
            self._keep(T, q_ref, exc, time.perf_counter() - t)
            raise
        self._keep(T, q_ref, out, time.perf_counter() - t)
        return out

    def _batch(self, poses: Sequence[FloatArray], q_refs: Sequence[FloatArray] = ()) -> list[Any]:
        assert self.ik.batch is not None
        t = time.perf_counter()
        outs = list(self.ik.batch(poses))
        dt = (time.perf_counter() - t) / max(1, len(poses))
        if len(outs) == len(poses):
            for T, out in zip(poses, outs, strict=True):
                self._keep(T, np.zeros(6), out, dt)
        return outs

    def user_ik(self) -> UserIk:
        """The IK to run with: ``ik``'s calls, each answer kept."""
        batch = self._batch if self.ik.batch is not None else None
        return UserIk(self.ik.spec, self._call, batch=batch, notes=self.ik.notes)

    def records(self, kin: Kinematics) -> tuple[list[dict[str, Any]], list[FloatArray]]:
        """The answers kept, judged as ik-check judges a case (named ``run pose N``, group
        ``run``; no branch change: the run judges jumps between neighbouring samples itself),
        and their poses."""
        no_q_ref = self.ik.batch is not None
        records, poses = [], []
        for i, (T, q_ref, raw, dt) in enumerate(self.asked, start=1):
            a = assess(kin, T, q_ref, raw, dt, no_q_ref=no_q_ref)
            r = case_record(kin, Case("run", f"run pose {i}", T, q_ref), a)
            r["branch_change"] = None
            records.append(r)
            poses.append(T)
        return records, poses


def run_findings(kin: Kinematics, watched: Watched, cycles: Sequence[Any]) -> list[Finding]:
    """The diagnosis of a run with a user's IK: its answers (:meth:`Watched.records`), its
    failed cycles (``cycles``: :class:`~kr210_sim.score.result.CycleResult`) and its notes."""
    records, poses = watched.records(kin)
    failed = [
        {"cycle": c.index, "slot": c.slot, "reason": c.reason, "detail": c.detail}
        for c in cycles
        if not c.success
    ]
    notes = notes_of(watched.ik)
    if not records and not failed and not notes:
        return []
    return diagnose(kin, records, poses, failed, notes, no_q_ref=watched.ik.batch is not None)


__all__ = ["MAX_KEPT", "Watched", "finding_lines", "notes_of", "run_findings"]
