"""Sampling-based motion planning with OMPL (the library MoveIt plans with).

The state space is the six arm joints within their limits; a state is valid when
:class:`~kr210_sim.plan.collide.CollisionChecker` finds no collision there (the cell with its
clearance, the arm itself, the held part as held and upright). RRTConnect finds a path, which is
then shortened (partial shortcuts, vertex reduction) within a time budget.

**Checking resolution.** Joint j moves the gripper's farthest point by at most ``r_j * |dq_j|``,
``r_j`` the sum of the link lengths from joint j's axis to the fingertips (the lever arm, from
the model). The space is a compound of one-joint subspaces weighted ``w_j = max(r_j, 1 cm / 1
deg)``, so its distance is the weighted L1 sum ``sum_j w_j |dq_j|`` [m], and OMPL checks motions
every 1 cm of that distance: no two checked states are more than 1 cm of gripper travel or 1 deg
per joint apart.

**Determinism.** Each plan seeds OMPL's random generator (``ompl.util.RNG``) from its own start
and goal, each joint rounded to :data:`SEED_GRID`, so a plan depends on nothing but its problem:
not on what was planned before it (any number of evaluation workers gives the same plans), not
on the run's seed, and not on the micrometres by which a cylinder settles on its board
(``check`` plans from the nominal slot, ``run`` from the settled cylinder: seeded from the exact
ends, the two searched with other random numbers, and a move RRTConnect solves with some of them
only was served by one and refused by the other). The search's budget is a number of
validity checks (:data:`SOLVE_CHECKS`), never seconds, and simplification runs a fixed number of
rounds, so a loaded or slow machine finds the same paths as a quiet one, only later. A move
one search cannot solve is searched again with other seeds drawn from the same ends, larger
budgets and another planner (:mod:`kr210_sim.plan.escalation`, by the caller).
"""

from __future__ import annotations

import hashlib
import itertools
import math
import time
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from kr210_sim.errors import NoPathError
from kr210_sim.plan.collide import HOLD_TILT_DEG, SAMPLE_ANGLE, SAMPLE_TRAVEL, CollisionChecker

import mujoco  # isort: skip

FloatArray = npt.NDArray[np.float64]

#: Checking step of the search, in the weighted distance [m] (the result is checked again at
#: 1 cm before the arm may move).
COARSE_STEP = 0.16
#: Largest |q4| searched while holding a part [rad] (more when a move's own end lies beyond).
HELD_Q4 = math.pi / 4
#: RRTConnect's longest extension, in the weighted distance [m].
RRT_RANGE = 2.0
#: Most validity checks one RRTConnect search may make (~1 s of checks at ~30 us each here). A
#: budget in checks, not seconds, so that whether a plan is found does not depend on how busy
#: the machine is: the same ends give the same plan or the same ``no_path`` anywhere.
SOLVE_CHECKS = 30_000
#: Step [rad] each joint of a plan's ends is rounded to before the plan's seed is drawn from
#: them: ends a few micrometres of gripper travel apart (some 1e-6 rad a joint) get the same
#: seed unless a joint lies that close to a step's edge (a chance of about 1e-4 a joint).
SEED_GRID = 0.01
#: Most rounds of vertex reduction and close-vertex collapse.
SIMPLIFY_ROUNDS = 3

#: The OMPL planners a search may use, by name.
PLANNERS = {"RRTConnect": og.RRTConnect, "RRT": og.RRT}

ou.setLogLevel(ou.LogLevel.LOG_WARN)


@dataclass(frozen=True, slots=True)
class SampledPath:
    """A collision-free joint path found by OMPL.

    Attributes:
        waypoints: Joint states [rad], shape (k, 6), start and goal included; the straight
            joint-space segments between them are collision-free at the checking resolution.
        planning_s: Wall time of search and simplification [s].
        checks: Validity checks made.
        length: Length of the path in the weighted metric (an upper bound of the gripper's
            travel) [m].
    """

    waypoints: FloatArray
    planning_s: float
    checks: int
    length: float


def lever_arms(model: mujoco.MjModel) -> FloatArray:
    """Upper bound of each arm joint's distance to any point of the hand [m], shape (6,).

    The chain of joint anchors, the gripper_link origin and the farthest finger geom (centre
    distance plus bounding radius) of a cell model, at its reference pose.
    """
    d = mujoco.MjData(model)
    mujoco.mj_kinematics(model, d)
    anchors = [d.xanchor[model.joint(f"joint_{i}").id].copy() for i in range(1, 7)]
    grip = model.body("gripper_link").id
    anchors.append(d.xpos[grip].copy())
    hand = 0.0
    for g in range(model.ngeom):
        b = int(model.geom_bodyid[g])
        if b == grip or model.body_parentid[b] == grip:
            far = float(np.linalg.norm(d.geom_xpos[g] - d.xpos[grip])) + model.geom_rbound[g]
            hand = max(hand, far)
    links = np.linalg.norm(np.diff(np.array(anchors), axis=0), axis=1)
    return np.array([links[j:].sum() + hand for j in range(6)])


def plan_seed(q_start: FloatArray, q_goal: FloatArray, held: bool, attempt: int = 0) -> int:
    """OMPL seed of one plan: from its ends [rad], each joint in steps of :data:`SEED_GRID`,
    whether a part is held and which attempt at the move it is (0, the first: the seed of a
    single search; never 0)."""
    h = hashlib.sha256()
    for q in (q_start, q_goal):
        steps = np.rint(np.asarray(q, dtype=np.float64).reshape(6) / SEED_GRID).astype(np.int64)
        h.update(steps.tobytes())
    h.update(b"held" if held else b"free")
    if attempt:
        h.update(b"attempt %d" % attempt)
    return int.from_bytes(h.digest()[:4], "little") | 1


def _seed(n: int) -> None:
    """Seed OMPL; it logs an error when reseeded after its first use, which is what we want."""
    ou.setLogLevel(ou.LogLevel.LOG_NONE)
    ou.RNG.setSeed(n)
    ou.setLogLevel(ou.LogLevel.LOG_WARN)


class SamplingPlanner:
    """RRTConnect in the arm's joint space against a collision checker.

    Args:
        checker: The validity check (its :meth:`~CollisionChecker.hold` state is used).
        lower: Lower joint limits [rad], shape (6,).
        upper: Upper joint limits [rad], shape (6,).
    """

    def __init__(
        self, checker: CollisionChecker, lower: npt.ArrayLike, upper: npt.ArrayLike
    ) -> None:
        self.checker = checker
        self.lower = np.asarray(lower, dtype=np.float64)
        self.upper = np.asarray(upper, dtype=np.float64)
        self.weights = np.maximum(lever_arms(checker.model), SAMPLE_TRAVEL / SAMPLE_ANGLE)

    def _coordinates(self, held: bool) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """The search coordinates x (q = M x): the joints, or while holding (q1, q2, q3, q4,
        s, q6) with s = q2 + q3 + q5 the gripper's tilt in the arm's plane, bounded by the tilt
        limit, and q4 within :data:`HELD_Q4`. Straight lines in x are straight in q.

        Returns:
            M (6, 6), the lower and upper bounds of x, and x's weights (each at least the
            travel per radian of every joint it moves).
        """
        M = np.eye(6)
        lo, hi, w = self.lower.copy(), self.upper.copy(), self.weights.copy()
        if held:
            M[4, 1:3] = -1.0  # q5 = s - q2 - q3
            tilt = math.radians(HOLD_TILT_DEG)
            lo[3], hi[3] = max(lo[3], -HELD_Q4), min(hi[3], HELD_Q4)
            lo[4], hi[4] = -tilt, tilt
            w[1:3] += w[4]
        return M, lo, hi, w

    @staticmethod
    def _space(lo: FloatArray, hi: FloatArray, w: FloatArray) -> ob.CompoundStateSpace:
        space = ob.CompoundStateSpace()
        for a, b, weight in zip(lo, hi, w, strict=True):
            sub = ob.RealVectorStateSpace(1)
            bounds = ob.RealVectorBounds(1)
            bounds.setLow(0, float(a))
            bounds.setHigh(0, float(b))
            sub.setBounds(bounds)
            space.addSubspace(sub, float(weight))
        return space

    def distance(self, a: npt.ArrayLike, b: npt.ArrayLike) -> float:
        """The space's distance (weighted L1, an upper bound of gripper travel) [m]."""
        return float(np.sum(self.weights * np.abs(np.asarray(b) - np.asarray(a))))

    def plan(
        self,
        q_start: npt.ArrayLike,
        q_goal: npt.ArrayLike,
        held: bool = False,
        fine: bool = False,
        planner: str = "RRTConnect",
        seed: int = 0,
        checks: int = SOLVE_CHECKS,
    ) -> SampledPath:
        """A path from ``q_start`` to ``q_goal`` [rad].

        The search checks motions every :data:`COARSE_STEP` of the weighted distance, or every
        :data:`~kr210_sim.plan.collide.SAMPLE_TRAVEL` with ``fine``; a coarse path's segments
        must be checked again at the fine step (:meth:`segments_clear`, or by checking the
        trajectory timed along them) before the arm may follow them.

        Args:
            q_start: Start joint state [rad].
            q_goal: Goal joint state [rad].
            held: Whether a part is held (set it on the checker too): the search keeps the
                gripper near level (:meth:`_coordinates`).
            fine: Search at the fine step.
            planner: The OMPL planner: "RRTConnect" or "RRT" (both with range
                :data:`RRT_RANGE`).
            seed: Which seed of the ends to draw (:func:`plan_seed`'s ``attempt``).
            checks: Most validity checks of the search.

        Raises:
            NoPathError: When an end collides, or the planner finds no path within ``checks``
                validity checks.
        """
        step = SAMPLE_TRAVEL if fine else COARSE_STEP
        return self._plan(q_start, q_goal, held, step, planner, seed, checks)

    def check_ends(self, q_start: npt.ArrayLike, q_goal: npt.ArrayLike) -> None:
        """Raise :class:`NoPathError`, naming what blocks, when an end of a move collides or
        is outside the limits (under the checker's current hold): no search can help."""
        valid = self.checker.state_validity()
        for what, q in (("start", q_start), ("goal", q_goal)):
            q = np.asarray(q, dtype=np.float64).reshape(6)
            if not valid(q):
                hit = self.checker.scan(q[None])
                blocked = hit.describe() if hit is not None else "it is outside the limits"
                raise NoPathError(f"the {what} of the move collides: {blocked}")

    def segments_clear(self, way: FloatArray) -> bool:
        """Whether the straight segments between ``way``'s states are clear, checked every
        :data:`~kr210_sim.plan.collide.SAMPLE_TRAVEL` of the weighted distance."""
        for a, b in itertools.pairwise(way):
            n = max(1, math.ceil(self.distance(a, b) / SAMPLE_TRAVEL))
            qs = a + np.linspace(0.0, 1.0, n + 1)[:, None] * (b - a)
            if self.checker.scan(qs[1:-1]) is not None:
                return False
        return True

    def _plan(
        self,
        q_start: npt.ArrayLike,
        q_goal: npt.ArrayLike,
        held: bool,
        step: float,
        planner: str,
        seed: int,
        checks: int,
    ) -> SampledPath:
        """One search at checking ``step`` [m] (see :meth:`plan`)."""
        t0 = time.perf_counter()
        qs = np.asarray(q_start, dtype=np.float64).reshape(6)
        qg = np.asarray(q_goal, dtype=np.float64).reshape(6)
        checks0 = self.checker.checks
        self.check_ends(qs, qg)
        valid = self.checker.state_validity()
        _seed(plan_seed(qs, qg, held, seed))
        M, lo, hi, w = self._coordinates(held)
        M_inv = np.linalg.inv(M)
        xs, xg = M_inv @ qs, M_inv @ qg
        # the held bounds (wrist roll, tilt) grow to take in the move's own ends: a part picked
        # with the wrist twisted (a pick off the radial) starts outside them
        lo, hi = np.minimum(lo, np.minimum(xs, xg)), np.maximum(hi, np.maximum(xs, xg))
        space = self._space(lo, hi, w)
        ss = og.SimpleSetup(space)
        x = np.empty(6)
        q_lo, q_hi = self.lower, self.upper

        if held:  # only q5 = s - q2 - q3 can leave its limits

            def is_valid(state: ob.State) -> bool:
                for j in range(6):
                    x[j] = state[j][0]
                q5 = x[4] - x[1] - x[2]
                if not q_lo[4] <= q5 <= q_hi[4]:
                    return False
                x[4] = q5
                return valid(x)

        else:

            def is_valid(state: ob.State) -> bool:
                for j in range(6):
                    x[j] = state[j][0]
                return valid(x)

        ss.setStateValidityChecker(is_valid)
        si = ss.getSpaceInformation()
        si.setStateValidityCheckingResolution(step / space.getMaximumExtent())
        start, goal = space.allocState(), space.allocState()
        for j in range(6):
            start[j][0] = float(np.clip(xs[j], lo[j], hi[j]))
            goal[j][0] = float(np.clip(xg[j], lo[j], hi[j]))
        ss.setStartAndGoalStates(start, goal)
        if planner not in PLANNERS:
            raise ValueError(f"unknown OMPL planner {planner!r}: one of {sorted(PLANNERS)}")
        search = PLANNERS[planner](si)
        search.setRange(RRT_RANGE)
        ss.setPlanner(search)
        budget = checks0 + checks
        ss.solve(ob.PlannerTerminationCondition(lambda: self.checker.checks >= budget))
        if not ss.haveExactSolutionPath():
            raise NoPathError(
                f"OMPL's {planner} (seed {seed}) found no collision-free path within {checks} "
                f"validity checks ({self.checker.checks - checks0} states checked)"
            )
        path = ss.getSolutionPath()
        simplifier = og.PathSimplifier(si)
        # one round of partial shortcuts (single joints' detours cut), then vertex reduction
        # until it stops changing: column cell, 9 slots, 5 % shorter moves for 13 % more checks
        simplifier.partialShortcutPath(path, 0, 0, 0.33, 0.005)
        for _ in range(SIMPLIFY_ROUNDS):
            n0 = path.getStateCount()
            changed = simplifier.reduceVertices(path, 2 * n0, n0, 1.0)
            changed |= simplifier.collapseCloseVertices(path)
            if not changed:
                break
        n = path.getStateCount()
        way = np.array([[path.getState(i)[j][0] for j in range(6)] for i in range(n)]) @ M.T
        way[0], way[-1] = qs, qg
        length = sum(self.distance(a, b) for a, b in itertools.pairwise(way))
        return SampledPath(way, time.perf_counter() - t0, self.checker.checks - checks0, length)
