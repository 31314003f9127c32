"""Joint-space moves that keep clear of the cell: the direct move first, OMPL when it collides.

:class:`Router` takes a joint move from rest to rest. When the direct, phase-synchronised move
is clear (:mod:`kr210_sim.plan.collide`) it is used as it is. Otherwise OMPL plans a path
(:mod:`kr210_sim.plan.sampling_planner`; searched again with other seeds, budgets and planners
before the move is ``no_path``, :mod:`kr210_sim.plan.escalation`), which is timed through its
waypoints without stopping (:mod:`kr210_sim.plan.timing`); the timed samples are checked against
the cell again and against the position, velocity and acceleration limits before the arm may
move. Every result carries the planner used, the planning time and a lower bound of its
duration.

:func:`clear_ready` finds the collision-free joint state nearest a ready pose that collides.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt

from kr210_sim.errors import NoPathError, PlanningError
from kr210_sim.plan.collide import CollisionChecker, Hit, check_samples
from kr210_sim.plan.escalation import SCHEDULE, Attempt, escalate
from kr210_sim.plan.sampling_planner import SamplingPlanner
from kr210_sim.plan.timing import check_limits, path_bound, rest_to_rest_bound, time_path
from kr210_sim.plan.trajectory import JointLimits, Trajectory, plan_ptp
from kr210_sim.robot.kinematics import Kinematics

FloatArray = npt.NDArray[np.float64]

#: Samples of a planned trajectory whose time-optimal parametrisation is its bound (80: within
#: 1 % of the value 800 converge to, and below it, on the column cell's planned moves).
BOUND_SAMPLES = 80
#: Moves a router remembers (the last ones planned): a move planned again from the same start
#: to the same goal under the same hold is the same move (OMPL is seeded from its ends).
REMEMBERED = 64
#: Radii of the rings searched for a clear ready pose, in the planner's weighted distance [m].
READY_RINGS = np.linspace(0.05, 3.0, 60)
#: Candidates tried on each ring.
READY_TRIES = 60


@dataclass(frozen=True, slots=True)
class Routed:
    """A checked joint move.

    Attributes:
        trajectory: The timed move.
        planner: "direct" or "ompl".
        planning_time: Wall time of its planning and checks [s].
        bound: Lower bound of its duration at the joint velocity and acceleration limits [s].
        checks: Validity checks made for it.
        hit: What blocked the direct move (None when it was clear).
    """

    trajectory: Trajectory
    planner: str
    planning_time: float
    bound: float
    checks: int
    hit: Hit | None


class Router:
    """Direct joint moves, or OMPL paths around what blocks them.

    Args:
        checker: The collision checker of the cell.
        kin: The arm's kinematics.
        limits: Joint limits.
        grip_limits: Joint limits of moves that hold the target (default: ``limits``): a move
            is timed with them when the checker holds a target (:meth:`~CollisionChecker.hold`).
        schedule: The OMPL searches tried in turn before a move is ``no_path``
            (:mod:`kr210_sim.plan.escalation`).
    """

    def __init__(
        self,
        checker: CollisionChecker,
        kin: Kinematics,
        limits: JointLimits,
        grip_limits: JointLimits | None = None,
        schedule: Sequence[Attempt] = SCHEDULE,
    ) -> None:
        self.checker = checker
        self.kin = kin
        self.limits = limits
        self.grip_limits = grip_limits or limits
        self._planned: dict[bytes, Routed | NoPathError] = {}
        #: OMPL searches made (a remembered move is not searched again).
        self.searches = 0
        #: Those the first attempt of :attr:`schedule` did not solve.
        self.escalated = 0
        #: The attempts of every search, tried in turn (:func:`escalate`).
        self.schedule = tuple(schedule)
        self.sampler = SamplingPlanner(checker, limits.lower, limits.upper)

    def hit(self, traj: Trajectory) -> Hit | None:
        """The first collision along ``traj`` under the checker's current hold, or None."""
        return self.checker.scan(check_samples(traj, self.kin))

    def _clear(self, traj: Trajectory) -> bool:
        return self.hit(traj) is None

    def route(
        self, q_start: FloatArray, q_goal: FloatArray, phase: str, blocked: Hit | None = None
    ) -> Routed:
        """A clear move from rest at ``q_start`` to rest at ``q_goal`` [rad], checked under the
        checker's current :meth:`~CollisionChecker.hold` (and timed at :attr:`grip_limits`
        when it holds a target).

        Args:
            q_start: Start [rad].
            q_goal: Goal [rad].
            phase: The move's phase, for messages.
            blocked: What blocks the direct move when the caller checked it already (it is
                then not checked again).

        The last :data:`REMEMBERED` moves (and ``no_path`` verdicts) are remembered by start,
        goal, hold and phase: asked again, the router answers without planning.

        Raises:
            NoPathError: When the direct move collides and no search of :attr:`schedule`
                finds a clear path; the message says what blocks the direct move, the searches
                and the validity checks they made.
            PlanningError: When a trajectory breaks a limit.
        """
        t0 = time.perf_counter()
        q0 = np.asarray(q_start, dtype=np.float64)
        q1 = np.asarray(q_goal, dtype=np.float64)
        key = q0.tobytes() + q1.tobytes() + self.checker.hold_key + phase.encode()
        remembered = key in self._planned
        if not remembered:
            try:
                result: Routed | NoPathError = self._route(q0, q1, phase, blocked)
            except NoPathError as exc:
                result = exc
            if len(self._planned) >= REMEMBERED:
                del self._planned[next(iter(self._planned))]
            self._planned[key] = result
        result = self._planned[key]
        if isinstance(result, NoPathError):
            raise NoPathError(str(result))
        took = time.perf_counter() - t0
        if remembered:  # the same plan, without a search or a check
            return replace(result, planning_time=took, checks=0)
        return replace(result, planning_time=took)

    def _route(
        self, q_start: FloatArray, q_goal: FloatArray, phase: str, blocked: Hit | None
    ) -> Routed:
        """:meth:`route`, planned."""
        t0, checks0 = time.perf_counter(), self.checker.checks
        held = self.checker.holding
        limits = self.grip_limits if held else self.limits
        hit = blocked
        if hit is None:
            direct = plan_ptp(q_start, q_goal, limits)
            hit = self.hit(direct)
        if hit is None:
            bound = rest_to_rest_bound(q_start, q_goal, limits)
            return Routed(
                direct,
                "direct",
                time.perf_counter() - t0,
                bound,
                self.checker.checks - checks0,
                None,
            )
        self.searches += 1

        def search(attempt: Attempt) -> Trajectory:
            """One attempt: the coarse search's path timed and checked at the fine step; when
            that is not clear even along its straight segments, a fine search's."""
            how = (attempt.planner, attempt.seed, attempt.checks)
            path = self.sampler.plan(q_start, q_goal, held, False, *how)
            try:
                return time_path(path.waypoints, limits, self._clear)[0]
            except PlanningError:
                path = self.sampler.plan(q_start, q_goal, held, True, *how)
                return time_path(path.waypoints, limits, self._clear)[0]

        try:
            self.sampler.check_ends(q_start, q_goal)  # no search helps then
            found = escalate(search, lambda: self.checker.checks, self.schedule)
        except NoPathError as exc:
            raise NoPathError(f"{phase} move: {hit.describe()}; {exc}") from exc
        self.escalated += found.attempt > 0
        traj = found.result
        check_limits(traj, limits)
        qs = traj.sample_many(np.linspace(0.0, traj.duration, BOUND_SAMPLES))[0]
        bound = path_bound(qs, limits)
        return Routed(
            traj, "ompl", time.perf_counter() - t0, bound, self.checker.checks - checks0, hit
        )


def path_lengths(traj: Trajectory, kin: Kinematics) -> tuple[float, float]:
    """Length of a move's path in joint space (Euclidean, [rad]) and of the gripper_link
    origin's path [m], from samples at most 1 cm and 1 deg apart."""
    q = check_samples(traj, kin)
    p = kin.forward(q)[:, :3, 3]
    joint = float(np.linalg.norm(np.diff(q, axis=0), axis=1).sum())
    return joint, float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())


def clear_ready(
    checker: CollisionChecker, q: npt.ArrayLike, sampler: SamplingPlanner
) -> tuple[FloatArray, Hit | None]:
    """The ready pose ``q`` [rad] if it is clear (nothing held), else the clear joint state
    nearest it in the planner's weighted distance, found on growing rings of deterministic
    samples.

    Returns:
        The clear pose and what blocked ``q`` (None when ``q`` was clear).

    Raises:
        PlanningError: When no clear state lies within the searched rings.
    """
    q0 = np.asarray(q, dtype=np.float64)
    checker.hold(None, None)
    blocked = checker.scan(q0[None])
    if blocked is None:
        return q0, None
    rng = np.random.default_rng(0)
    lo, hi = sampler.lower, sampler.upper
    valid = checker.state_validity()
    for r in READY_RINGS:
        best, best_d = None, np.inf
        for _ in range(READY_TRIES):
            u = rng.normal(size=6) / sampler.weights
            cand = np.clip(q0 + u * r / sampler.distance(np.zeros(6), u), lo, hi)
            d = sampler.distance(q0, cand)
            if d < best_d and valid(cand):
                best, best_d = cand, d
        if best is not None:
            return best, blocked
    raise PlanningError(
        f"the ready pose collides ({blocked.describe()}) and no clear pose lies within "
        f"{READY_RINGS[-1]:.1f} m of gripper travel of it: set [robot] ready_q in the cell file"
    )
