"""Task planning: the gripper poses and joint trajectories of one pick-and-place cycle.

A cycle is planned from the target's *observed* pose (position and size), never from the nominal
slot. Every gripper pose keeps the gripper level (its z axis up) and points it *radially*, along
the horizontal line from the joint_1 axis through the target (or the drop point). The published
plan points the gripper along +x everywhere; pointing it radially keeps the wrist untwisted
(q4 = q6 = 0, q5 = -(q2 + q3)), so the phase-synchronised joint moves between such poses keep
the gripper exactly level all the way (the joints move on proportional profiles), the cylinder
stays upright, and the swing's centripetal pull acts along the fingers towards the fingertip
lips, which stop it.

:meth:`Planner.plan_cycle` returns the whole cycle as one
:class:`~kr210_sim.plan.cycle.CyclePlan`, these steps in order (phase names are what the runner
records, the video shows and view's demo mode stops before)::

    approach  PTP   ready -> standoff (in front of the target, clear of the shelf)
    approach  LIN   standoff -> grasp (fingers straddle the cylinder)
    grasp     grip  close until the grip is confirmed
    lift      LIN   straight up by ``lift``
    retreat   LIN   straight back out of the shelf to the standoff (lifted)
    carry     PTP   to the drop pose above the bin
    release   grip  open, wait
    return    PTP   back to the ready pose

The carry goes to the cell's drop spots in turn, those a dropped cylinder reaches the bin's
floor from (:func:`~kr210_sim.plan.cycle.drop_spot_order`), and the pick starts from the
standoff's IK solution nearest the start. When that cycle cannot be planned, the other drop
spots and the other branches are tried, a step down either list counting alike
(:func:`~kr210_sim.plan.cycle.pick_order`): the first cycle that can be planned is run.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np
import numpy.typing as npt

from kr210_sim.cell.layout import ready_q_of
from kr210_sim.cell.spec import MotionConfig, TargetSpec
from kr210_sim.errors import IkFailedError, NoPathError, PlanningError, UnreachablePoseError
from kr210_sim.plan.collide import CollisionChecker, Hit, check_samples
from kr210_sim.plan.cycle import (
    CyclePlan,
    GraspPlan,
    Grip,
    Move,
    Step,
    drop_spot_order,
    pick_order,
)
from kr210_sim.plan.ik_branch import BranchLog
from kr210_sim.plan.poses import (
    GRASP_HEADINGS,
    branch_solutions,
    grasp_depth,
    pick_poses,
    radial_yaw,
    release_pose,
    untwisted_nearest,
)
from kr210_sim.plan.routing import Router, clear_ready
from kr210_sim.plan.timing import rest_to_rest_bound
from kr210_sim.plan.trajectory import JointLimits, line_poses, plan_cartesian_line, plan_ptp
from kr210_sim.robot.description import RobotDescription
from kr210_sim.robot.kinematics import Kinematics
from kr210_sim.sandbox.ik_guard import CheckedIk
from kr210_sim.sandbox.user_ik import UserIk

FloatArray = npt.NDArray[np.float64]


class Planner:
    """Plans the moves of a cycle with closed-form IK and ruckig.

    Args:
        robot: The robot description: every pose is solved and every path checked with its
            kinematics (:attr:`kinematics`).
        motion: Motion settings.
        ik: A user's IK function to plan with instead of :meth:`Kinematics.nearest`; every
            answer is checked (:class:`~kr210_sim.sandbox.ik_guard.CheckedIk`) and a bad one raises
            :class:`~kr210_sim.errors.IkFailedError`.
        checker: Checks every move against the cell (:mod:`kr210_sim.plan.collide`); a joint-space
            move that collides is planned again by OMPL (:mod:`kr210_sim.plan.routing`), and a
            move with no collision-free plan raises :class:`~kr210_sim.errors.NoPathError`.
            With a checker, the ready pose is the cell's (``[robot] ready_q``) when it sets one,
            and the clear pose nearest it when it collides. None: moves are not checked.
            OMPL's searches are seeded from their own ends, not from the run's seed: a cell
            ``check`` serves is served in a run of any seed.
    """

    def __init__(
        self,
        robot: RobotDescription,
        motion: MotionConfig,
        ik: UserIk | None = None,
        checker: CollisionChecker | None = None,
    ) -> None:
        self.robot = robot
        #: The kinematics of ``robot``.
        self.kinematics = Kinematics(robot)
        self.motion = motion
        #: Joint limits of the joint moves with the gripper empty, and of the moves into, with
        #: and out of the grip (a gentler jerk, :class:`~kr210_sim.cell.spec.MotionConfig`).
        self.limits = JointLimits.from_robot(robot, motion)
        self.grip_limits = JointLimits.from_robot(robot, motion, grip=True)
        self.ready_q = np.asarray(motion.ready_q, dtype=np.float64)
        self.user_ik = CheckedIk(ik, self.kinematics) if ik is not None else None
        self.ik_branches = BranchLog()  # the user's answers against the built-in branch
        self.checker = checker
        #: Moves planned by OMPL around what blocked the direct move so far.
        self.detours = 0
        #: What blocked the configured ready pose (empty when it was clear and used).
        self.ready_note = ""
        self._returns: dict[bytes, Move] = {}
        self.router: Router | None = None
        if checker is not None:
            self.router = Router(checker, self.kinematics, self.limits, self.grip_limits)
            cell_ready = ready_q_of(checker.model)
            if cell_ready is not None:
                self.ready_q = cell_ready
            if self._ready_in_limits():
                self._clear_ready(checker)

    def _clear_ready(self, checker: CollisionChecker) -> None:
        """Use the clear pose nearest the ready pose when it collides (:attr:`ready_note`)."""
        assert self.router is not None
        try:
            clear, blocked = clear_ready(checker, self.ready_q, self.router.sampler)
        except PlanningError as exc:  # kept: every cycle's first move says what blocks it
            self.ready_note = str(exc)
            return
        if blocked is not None:
            moved = np.degrees(clear - self.ready_q)
            self.ready_note = (
                f"the ready pose collides ({blocked.describe()}): the nearest clear one is "
                f"used, moved by {np.round(moved, 1).tolist()} deg"
            )
            self.ready_q = clear

    # -- collision checks ------------------------------------------------------------------
    def held_offset(self, radius: float) -> FloatArray:
        """Centre of a held target in the gripper_link frame [m]."""
        return np.array([grasp_depth(self.robot, radius), 0.0, -self.motion.grasp_dz])

    def _hit(self, move: Move, held: TargetSpec | None) -> Hit | None:
        if self.checker is None:
            return None
        offset = None if held is None else self.held_offset(held.radius)
        samples = check_samples(move.trajectory, self.kinematics)
        return self.checker.first_hit(samples, held, offset)

    def checked(self, move: Move, held: TargetSpec | None = None) -> Move:
        """``move`` if it keeps clear of the cell; a joint-space move that collides is planned
        again around what blocks it (OMPL, :class:`~kr210_sim.plan.routing.Router`).

        Raises:
            NoPathError: When a straight-line move collides, or a joint-space move collides and
                OMPL finds no clear path; the message says what blocks.
        """
        t0 = time.perf_counter()
        hit = self._hit(move, held)
        if hit is None or self.router is None:
            return replace(move, planning_time=move.planning_time + time.perf_counter() - t0)
        if move.kind != "ptp":
            raise NoPathError(f"{move.phase} straight-line move: {hit.describe()}")
        routed = self.router.route(move.trajectory.q_start, move.q_end, move.phase, hit)
        self.detours += 1
        return Move(
            move.phase,
            "ptp",
            routed.trajectory,
            routed.planner,
            move.planning_time + time.perf_counter() - t0,
            routed.bound,
        )

    def ptp(self, phase: str, q_start: FloatArray, q_goal: FloatArray, grip: bool = False) -> Move:
        """A joint-space move at rest at both ends (``grip``: at :attr:`grip_limits`)."""
        t0 = time.perf_counter()
        limits = self.grip_limits if grip else self.limits
        traj = plan_ptp(q_start, q_goal, limits)
        bound = rest_to_rest_bound(q_start, q_goal, limits)
        return Move(phase, "ptp", traj, "direct", time.perf_counter() - t0, bound)

    def lin(self, phase: str, q_start: FloatArray, T_goal: FloatArray, grip: bool = True) -> Move:
        """A straight-line Cartesian move from the pose at ``q_start`` to ``T_goal`` (at
        :attr:`grip_limits` unless ``grip`` is False)."""
        t0 = time.perf_counter()
        T_start = self.kinematics.forward(q_start)
        ik: Callable[[FloatArray, FloatArray], FloatArray] = self.kinematics.nearest
        if self.user_ik is not None:  # a ROS-form server gets the line in one request
            self.user_ik.prefetch(line_poses(T_start, T_goal, self.motion.lin_step))
            ik = self.user_ik.line_ik(f"{phase} line")
        traj = plan_cartesian_line(
            T_start,
            T_goal,
            q_start,
            ik,
            self.grip_limits if grip else self.limits,
            speed=self.motion.lin_speed,
            step=self.motion.lin_step,
        )
        return Move(phase, "lin", traj, "direct", time.perf_counter() - t0, traj.bound)

    def solve(
        self, T: FloatArray, q_ref: FloatArray, what: str, untwisted: bool = False
    ) -> FloatArray:
        """IK for ``T`` nearest ``q_ref``, with the pose named in the error message
        (``untwisted``: preferring an untwisted wrist, :func:`untwisted_nearest`)."""
        if self.user_ik is not None:
            q = self.user_ik.solve(T, q_ref, f"{what} pose")
            return self.ik_branches.see(T, q_ref, q, what, untwisted, self)
        try:
            if untwisted:
                return untwisted_nearest(self.kinematics, T, q_ref)
            return self.kinematics.nearest(T, q_ref)
        except UnreachablePoseError as exc:
            raise UnreachablePoseError(f"{what} pose {T[:3, 3].round(3).tolist()}: {exc}") from exc

    def branches(self, T: FloatArray, q_ref: FloatArray, what: str) -> list[FloatArray]:
        """The solutions for ``T`` a pick tries in turn (:func:`branch_solutions`; the user's
        IK gives one), the pose named in the error message.

        Raises:
            UnreachablePoseError: When there is none.
            IkFailedError: When the user's IK gives an unusable answer.
        """
        if self.user_ik is not None:
            return [self.solve(T, q_ref, what)]
        try:
            return branch_solutions(self.kinematics, T, q_ref)
        except UnreachablePoseError as exc:
            raise UnreachablePoseError(f"{what} pose {T[:3, 3].round(3).tolist()}: {exc}") from exc

    def _standoff(self, T: FloatArray, q_ref: FloatArray, branch: int) -> FloatArray:
        """Solution ``branch`` of :meth:`branches` for the standoff ``T``.

        Raises:
            UnreachablePoseError: When the pose has no solution, or fewer than ``branch`` + 1.
        """
        if branch == 0:
            return self.solve(T, q_ref, "standoff")
        found = self.branches(T, q_ref, "standoff")
        if branch >= len(found):
            raise UnreachablePoseError(f"standoff pose: no IK branch {branch + 1}")
        return found[branch]

    def grasp_poses(
        self, target_position: npt.ArrayLike, target_radius: float, yaw: float | None = None
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """:func:`~kr210_sim.plan.poses.pick_poses` of this planner's robot and motion."""
        return pick_poses(self.robot, self.motion, target_position, target_radius, yaw)

    def plan_grasp(
        self,
        q_start: FloatArray,
        target_position: npt.ArrayLike,
        target_radius: float,
        held_length: float | None = None,
        branch: int = 0,
    ) -> GraspPlan:
        """Plan ready -> standoff -> grasp -> lift -> retreat for a target.

        The gripper points radially (see the module doc). When a pose or a straight line of that
        pick collides (an obstacle beside the shelf, in the way of the wrist), the headings
        :data:`GRASP_HEADINGS` off the radial are tried in turn, those whose four poses are
        clear only: a cylinder can be gripped from any side. The joint move to the chosen
        standoff is planned last (OMPL when the direct one collides).

        Args:
            q_start: Arm joint state at the start [rad].
            target_position: Observed target centre [m].
            target_radius: Target radius [m].
            held_length: Target length [m], for the collision checks of the held target.
            branch: Which IK solution of each heading's standoff to start the straight lines
                from (:meth:`branches`: 0, the one nearest ``q_start``).

        Raises:
            UnreachablePoseError: When a pose of the radial pick has no IK solution inside the
                limits (or its standoff fewer than ``branch`` + 1).
            NoPathError: When a straight line collides at every heading (the message says what
                blocks the radial one), or the approach collides and OMPL finds no clear path.
            IkFailedError: When the user's IK gives an unusable answer.
            PlanningError: When a trajectory breaks a limit.
        """
        p = np.asarray(target_position, dtype=np.float64)
        radial = radial_yaw(p)
        held = TargetSpec(radius=target_radius, length=held_length or 0.25)
        try:
            yaw, lines = radial, self._pick_lines(q_start, p, target_radius, held, radial, branch)
        except NoPathError as blocked:
            yaw, lines = self._other_heading(q_start, p, target_radius, held, blocked, branch)
        approach_lin, lift, retreat = lines
        approach_ptp = self.ptp("approach", q_start, approach_lin.trajectory.q_start)
        if self.checker is not None:
            approach_ptp = self.checked(approach_ptp)
        T_grasp = self.grasp_poses(p, target_radius, yaw)[1]
        return GraspPlan(T_grasp, approach_ptp, approach_lin, lift, retreat, yaw)

    def _pick_lines(
        self,
        q_start: FloatArray,
        p: FloatArray,
        radius: float,
        held: TargetSpec,
        yaw: float,
        branch: int = 0,
    ) -> tuple[Move, Move, Move]:
        """The straight lines of a pick at heading ``yaw`` [rad] (approach, lift, retreat from
        the standoff's solution ``branch``, :meth:`branches`), checked against the cell.

        Raises:
            NoPathError: When one collides (its ends included).
        """
        T_standoff, T_grasp, T_lift, T_back = self.grasp_poses(p, radius, yaw)
        q_standoff = self._standoff(T_standoff, q_start, branch)
        approach_lin = self.lin("approach", q_standoff, T_grasp)
        lift = self.lin("lift", approach_lin.q_end, T_lift)
        retreat = self.lin("retreat", lift.q_end, T_back)
        if self.checker is not None:
            approach_lin = self.checked(approach_lin)
            lift = self.checked(lift)  # the target starts on its board: the arm alone is checked
            retreat = self.checked(retreat, held)
        return approach_lin, lift, retreat

    def _other_heading(
        self,
        q_start: FloatArray,
        p: FloatArray,
        radius: float,
        held: TargetSpec,
        blocked: NoPathError,
        branch: int = 0,
    ) -> tuple[float, tuple[Move, Move, Move]]:
        """The first heading of :data:`GRASP_HEADINGS` whose pick's poses and lines are clear.

        Raises:
            NoPathError: When none is (``blocked``, what blocks the radial pick, and that).
        """
        radial = radial_yaw(p)
        for offset in GRASP_HEADINGS:
            yaw = radial + math.radians(offset)
            if not self._poses_clear(q_start, p, radius, held, yaw, branch):
                continue
            try:
                return yaw, self._pick_lines(q_start, p, radius, held, yaw, branch)
            except (NoPathError, UnreachablePoseError, IkFailedError):
                continue
        widest = max(GRASP_HEADINGS)
        raise NoPathError(
            f"{blocked}; no other heading within {widest} deg of the radial is clear either"
        ) from blocked

    def _poses_clear(
        self,
        q_start: FloatArray,
        p: FloatArray,
        radius: float,
        held: TargetSpec,
        yaw: float,
        branch: int = 0,
    ) -> bool:
        """Whether the standoff (its solution ``branch``), grasp, lift and lifted standoff at
        heading ``yaw`` [rad] have IK solutions that keep clear of the cell (four checks,
        before the lines are planned)."""
        assert self.checker is not None
        T_standoff, T_grasp, T_lift, T_back = self.grasp_poses(p, radius, yaw)
        try:
            q = [self._standoff(T_standoff, q_start, branch)]
            for T in (T_grasp, T_lift, T_back):
                q.append(self.solve(T, q[-1], "grasp"))
        except (UnreachablePoseError, IkFailedError):
            return False
        if self.checker.first_hit(np.array(q[:3])) is not None:
            return False
        return self.checker.first_hit(q[3][None], held, self.held_offset(radius)) is None

    def drop_pose(self, drop_xy: npt.ArrayLike, target_radius: float) -> FloatArray:
        """:func:`~kr210_sim.plan.poses.release_pose` of this planner's robot and motion."""
        return release_pose(self.robot, self.motion, drop_xy, target_radius)

    def plan_carry(
        self,
        q_start: FloatArray,
        drop_xy: npt.ArrayLike,
        target_radius: float,
        target_length: float = 0.25,
    ) -> Move:
        """Joint-space move from ``q_start`` to release the target above ``drop_xy`` [m]
        (checked with the target held, detoured if it must be)."""
        q_drop = self.solve(self.drop_pose(drop_xy, target_radius), q_start, "drop", True)
        held = TargetSpec(radius=target_radius, length=target_length)
        return self.checked(self.ptp("carry", q_start, q_drop, grip=True), held)

    def plan_return(self, q_start: FloatArray) -> Move:
        """Joint-space move from ``q_start`` back to the ready pose (checked, detoured if it
        must be; the last one is remembered, so planning it ahead costs nothing later)."""
        key = np.asarray(q_start, dtype=np.float64).tobytes()
        if key not in self._returns:
            self._returns = {key: self.checked(self.ptp("return", q_start, self.ready_q))}
        return self._returns[key]

    def plan_cycle(
        self,
        q_start: FloatArray,
        target_position: npt.ArrayLike,
        target: TargetSpec,
        drop_spots: npt.ArrayLike,
        placed: int = 0,
        usable: Sequence[int] | None = None,
        dropped: Sequence[int] | None = None,
    ) -> CyclePlan:
        """Plan the whole cycle for a target before the arm moves (see the module doc).

        The pick starts from the standoff's IK solution nearest ``q_start`` and carries to the
        drop spot in turn; when that cycle cannot be planned, the other branches and drop spots
        are tried (:func:`~kr210_sim.plan.cycle.pick_order`), and the first whole cycle is used.

        Args:
            q_start: Arm joint state at the start [rad].
            target_position: Observed target centre [m].
            target: The target's size (radius and length; the held target is checked with it).
            drop_spots: The cell's drop spots, shape (n, 2): (x, y) [m].
            placed: Targets put in play since the bin was last emptied, this one not counted:
                it picks the drop spot (:func:`~kr210_sim.plan.cycle.drop_spot_order`).
            usable: The drop spots to carry to (0-based; default: all); see :meth:`plan_place`.
            dropped: Cylinders carried to each drop spot since the bin was emptied (see
                :func:`~kr210_sim.plan.cycle.drop_spot_order`), or None.

        Raises:
            UnreachablePoseError: When a pose has no IK solution inside the limits.
            NoPathError: When a move collides with the cell and no detour is clear.
            IkFailedError: When the user's IK gives an unusable answer.
            PlanningError: When a trajectory breaks a limit.
            (What stops the first cycle tried, when none can be planned.)
        """
        t0, c0 = time.perf_counter(), time.process_time()
        r = target.radius
        spots = np.asarray(drop_spots, dtype=np.float64).reshape(-1, 2)
        order = drop_spot_order(placed, range(len(spots)) if usable is None else usable, dropped)
        if not order:
            raise PlanningError("no drop spot to carry the target to")
        g, place = self._first_cycle(q_start, target_position, target, spots, order)
        T_standoff, T_grasp, T_lift, T_back = self.grasp_poses(target_position, r, g.yaw)
        steps = (
            Step("approach", g.approach_ptp, pose="standoff", T=T_standoff),
            Step("approach", g.approach_lin, pose="grasp", T=T_grasp),
            Step("grasp", grip=Grip.CLOSE, wait=self.motion.close_timeout),
            Step("lift", g.lift, pose="lift", T=T_lift),
            Step("retreat", g.retreat, pose="retreat", T=T_back),
            *place.steps,
        )
        return CyclePlan(
            steps,
            place.drop_spot,
            place.drop_xy,
            sum(s.move.planner == "ompl" for s in steps if s.move is not None),
            time.perf_counter() - t0,
            time.process_time() - c0,
            math.remainder(g.yaw - radial_yaw(target_position), 2 * math.pi),
        )

    def _first_cycle(
        self,
        q_start: FloatArray,
        target_position: npt.ArrayLike,
        target: TargetSpec,
        spots: FloatArray,
        order: tuple[int, ...],
    ) -> tuple[GraspPlan, CyclePlan]:
        """The pick and the place of the first (drop spot, branch) pair in :func:`pick_order`
        whose cycle can be planned: drop spots ranked as ``order``, branches as
        :meth:`branches`.

        Raises:
            UnreachablePoseError, NoPathError, IkFailedError, PlanningError: The first pair's,
                when no pair can be planned (an unusable answer of the user's IK at once).
        """
        user = self.user_ik is not None  # the user's IK gives one branch: no other is tried
        r = target.radius
        n_branches = 1 if user else max(1, self._n_branches(target_position, r, q_start))
        grasps: dict[int, GraspPlan | UnreachablePoseError | PlanningError] = {}
        first: UnreachablePoseError | PlanningError | None = None
        for spot_rank, branch in pick_order(len(order), n_branches):
            if branch not in grasps:
                try:
                    grasps[branch] = self.plan_grasp(
                        q_start, target_position, r, target.length, branch
                    )
                except (UnreachablePoseError, PlanningError) as exc:
                    grasps[branch] = exc
            g = grasps[branch]
            if isinstance(g, Exception):
                first = first or g
                if user:
                    raise g
                continue
            try:
                return g, self._place_at(g.retreat.q_end, target, spots, order[spot_rank])
            except (UnreachablePoseError, PlanningError) as exc:
                first = first or exc
                if isinstance(exc, IkFailedError):  # the user's IK is judged on the spot in turn
                    raise
        assert first is not None
        raise first

    def _n_branches(self, target_position: npt.ArrayLike, radius: float, q_ref: FloatArray) -> int:
        """IK branches of the radial standoff (0 when it is out of reach)."""
        try:
            return len(self.branches(self.grasp_poses(target_position, radius)[0], q_ref, ""))
        except UnreachablePoseError:
            return 0

    def plan_place(
        self,
        q_start: FloatArray,
        target: TargetSpec,
        drop_spots: npt.ArrayLike,
        placed: int = 0,
        usable: Sequence[int] | None = None,
        dropped: Sequence[int] | None = None,
    ) -> CyclePlan:
        """Plan the place part of a cycle, the target held at ``q_start`` [rad]: carry to a
        drop spot, release, return to the ready pose (:meth:`plan_cycle` ends with these steps;
        ``check`` plans each drop spot with them).

        The drop spot is the one in turn among ``usable``; when its place cannot be planned
        (the drop pose out of reach, the carry or the return blocked), the next usable one in
        turn, and so on (:func:`~kr210_sim.plan.cycle.drop_spot_order`).

        Args:
            q_start: Arm joint state at the start, holding the target [rad].
            target: The target's size.
            drop_spots: The cell's drop spots, shape (n, 2): (x, y) [m].
            placed: Picks the drop spot in turn.
            usable: The drop spots to carry to (0-based, in the cell's order; default: all):
                those a dropped cylinder reaches the bin's floor from
                (:func:`~kr210_sim.plan.landing.usable_drop_spots`).
            dropped: Cylinders carried to each drop spot since the bin was emptied: the least
                used are tried first (:func:`~kr210_sim.plan.cycle.drop_spot_order`).

        Raises:
            UnreachablePoseError, NoPathError, IkFailedError, PlanningError: As
                :meth:`plan_cycle`, for the drop spot in turn, when no usable one can be planned.
        """
        spots = np.asarray(drop_spots, dtype=np.float64).reshape(-1, 2)
        all_spots = range(len(spots))
        order = drop_spot_order(placed, all_spots if usable is None else usable, dropped)
        if not order:
            raise PlanningError("no drop spot to carry the target to")
        first: UnreachablePoseError | PlanningError | None = None
        for spot in order:
            try:
                return self._place_at(q_start, target, spots, spot)
            except IkFailedError:  # the user's IK is judged on the spot in turn
                raise
            except (UnreachablePoseError, PlanningError) as exc:
                first = first or exc
        assert first is not None
        raise first

    def _place_at(
        self, q_start: FloatArray, target: TargetSpec, spots: FloatArray, spot: int
    ) -> CyclePlan:
        """:meth:`plan_place` to drop spot ``spot`` (0-based)."""
        t0, c0 = time.perf_counter(), time.process_time()
        r = target.radius
        drop = spots[spot]
        carry = self.plan_carry(q_start, drop, r, target.length)
        back = self.plan_return(carry.q_end)
        steps = (
            Step("carry", carry, pose="drop", T=self.drop_pose(drop, r)),
            Step("release", grip=Grip.OPEN, wait=self.motion.release_wait),
            Step("return", back),
        )
        return CyclePlan(
            steps,
            spot,
            (float(drop[0]), float(drop[1])),
            sum(m.planner == "ompl" for m in (carry, back)),
            time.perf_counter() - t0,
            time.process_time() - c0,
        )

    def _ready_in_limits(self) -> bool:
        lo, hi = self.robot.q_lower, self.robot.q_upper
        return not (np.any(self.ready_q < lo) or np.any(self.ready_q > hi))

    def check_ready(self) -> None:
        """Raise PlanningError when the configured ready pose breaks a joint limit."""
        if not self._ready_in_limits():
            raise PlanningError(f"ready_q {self.ready_q.tolist()} is outside the joint limits")
