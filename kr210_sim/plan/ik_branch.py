"""Which solution a user's IK answers, against the one the built-in IK would take, and what the
difference costs in motion time.

A pose of the KR210 has up to eight IK solutions. The built-in IK takes the one nearest the arm's
state (the carry's drop pose: the nearest with an untwisted wrist). A user's IK may answer
another, as correct: a ROS-form ``IK_server.py`` is never sent the arm's state (MoveIt sent
poses only), so one that does not keep its last answer picks a solution by its own rule, often
the same wrist every time. The arm then turns its wrist half a turn into the pose and back out
of it, and the cycle is longer for it, with nothing wrong in any answer. :class:`BranchLog`
compares each answer the planner takes from a user's IK on its own (not a straight line's
samples, whose every step is held to the previous one) with the built-in choice, and says in
the report's ``summary.ik.branches`` how many differed, how, and the time the difference adds
to the moves into and out of those poses (a lower bound: each move's slowest joint alone).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from kr210_sim.errors import UnreachablePoseError
from kr210_sim.plan.poses import untwisted_nearest
from kr210_sim.plan.timing import rest_to_rest_bound
from kr210_sim.plan.trajectory import JointLimits
from kr210_sim.robot.description import ARM_JOINTS
from kr210_sim.robot.kinematics import Kinematics
from kr210_sim.sandbox.ik_guard import branch_change

FloatArray = npt.NDArray[np.float64]

#: Largest joint difference [rad] of an answer still on the built-in solution's branch (a
#: correct closed form agrees to ~1e-12 rad; another branch differs by tenths of a radian).
SAME_BRANCH = 1e-3
#: The pose whose move out is the return to the ready pose (the carry's end).
DROP = "drop"


class PlannerView(Protocol):
    """What :meth:`BranchLog.see` reads of the planner (:class:`~kr210_sim.plan.planner.
    Planner`)."""

    kinematics: Kinematics
    limits: JointLimits
    grip_limits: JointLimits
    ready_q: FloatArray


@dataclass(frozen=True, slots=True)
class BranchNote:
    """One answer on another branch than the built-in IK's.

    Attributes:
        pose: Which pose ("standoff", "grasp", "drop").
        kind: How it differs (:func:`~kr210_sim.sandbox.ik_guard.branch_change`: "wrist
            flip", "2pi jump", "q4/q6 split", "arm branch change").
        difference_deg: The answer minus the built-in solution, per joint [deg].
        extra_s: The time the difference adds to the move into the pose and, for the drop pose,
            to the return to the ready pose out of it, by the moves' lower bounds [s] (negative
            when the user's branch is the quicker one).
    """

    pose: str
    kind: str
    difference_deg: tuple[float, ...]
    extra_s: float


@dataclass
class BranchLog:
    """The answers a user's IK gave on its own and those on another branch than ours."""

    answered: int = 0
    notes: list[BranchNote] = field(default_factory=list)

    def see(
        self,
        T: FloatArray,
        q_ref: FloatArray,
        q: FloatArray,
        pose: str,
        untwisted: bool,
        planner: PlannerView,
    ) -> FloatArray:
        """Compare the user's answer ``q`` for ``T`` from ``q_ref`` with the built-in choice
        (nearest ``q_ref``; ``untwisted``: with an untwisted wrist) and note a difference.

        Returns:
            ``q``, unchanged: the user's answer is what the arm moves to.
        """
        self.answered += 1
        kin = planner.kinematics
        try:
            ours = untwisted_nearest(kin, T, q_ref) if untwisted else kin.nearest(T, q_ref)
        except UnreachablePoseError:
            return q
        kind = branch_change(q, ours, SAME_BRANCH)
        if not kind:
            return q
        into = planner.grip_limits if pose == DROP else planner.limits
        extra = rest_to_rest_bound(q_ref, q, into) - rest_to_rest_bound(q_ref, ours, into)
        if pose == DROP:
            ready, lim = planner.ready_q, planner.limits
            extra += rest_to_rest_bound(q, ready, lim) - rest_to_rest_bound(ours, ready, lim)
        diff = tuple(round(float(d), 1) for d in np.degrees(np.asarray(q) - ours))
        self.notes.append(BranchNote(pose, kind, diff, round(extra, 3)))
        return q

    def summary(self, cycles: int, ros_form: bool) -> dict[str, Any]:
        """The report's ``summary.ik.branches`` block.

        Args:
            cycles: Cycles run (the extra time is also given per cycle).
            ros_form: The IK is a ROS-form server (the note then says it is sent no state).
        """
        by_pose: dict[str, dict[str, Any]] = {}
        for n in self.notes:
            entry = by_pose.setdefault(n.pose, {"count": 0, "kinds": {}, "extra_s": 0.0})
            entry["count"] += 1
            entry["kinds"][n.kind] = entry["kinds"].get(n.kind, 0) + 1
            entry["extra_s"] = round(entry["extra_s"] + n.extra_s, 3)
            entry["example_difference_deg"] = list(n.difference_deg)
        extra = float(sum(n.extra_s for n in self.notes))
        per_cycle = extra / cycles if cycles else 0.0
        return {
            "answered": self.answered,
            "other_branch": len(self.notes),
            "by_pose": by_pose,
            "extra_s": round(extra, 3),
            "extra_s_per_cycle": round(per_cycle, 3),
            "note": self._note(by_pose, per_cycle, ros_form),
        }

    def _note(self, by_pose: dict[str, dict[str, Any]], per_cycle: float, ros_form: bool) -> str:
        """One line saying why the cycles are longer (or that the branches are ours)."""
        if not self.notes:
            return (
                f"all {self.answered} poses answered on the branch the built-in IK takes "
                "(nearest the arm's state)"
            )
        parts = []
        for pose, e in by_pose.items():
            kinds = ", ".join(sorted(e["kinds"]))
            moved = [
                f"{ARM_JOINTS[j]} {d:+.0f} deg"
                for j, d in enumerate(e["example_difference_deg"])
                if abs(d) >= 1.0
            ]
            parts.append(f"{pose} {e['count']}x ({kinds}: {', '.join(moved)})")
        why = (
            "a ROS-form server is sent no joint state (MoveIt sent poses only): keep the last "
            "answer and return the solution nearest it"
            if ros_form
            else "return the solution nearest q_ref"
        )
        head = (
            f"{len(self.notes)} of {self.answered} poses answered on another branch than the "
            f"one nearest the arm's state that the built-in IK takes: {'; '.join(parts)}. "
        )
        if per_cycle <= 0.0:
            return head + f"The moves into and out of them take no longer ({per_cycle:+.2f} s)."
        return head + (
            f"The moves into and out of them take at least {per_cycle:.2f} s longer a cycle. "
            f"Correct, but slower: to move as little, {why}."
        )
