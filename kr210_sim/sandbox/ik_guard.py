"""Judge every answer a user's IK gives, with *our* forward kinematics, before anything moves.

* 2 pi twins: an angle outside its joint's limits, but within one turn of them, is replaced by
  its 2 pi twin when one lies inside (the twin nearest ``q_ref``), because a student's ``atan2``
  answers lie in (-pi, pi] while joints 1, 3, 4 and 6 reach past +-pi. An angle inside its
  limits is taken as given; one further out (``1e300``) stays outside and is refused.
* The answer must be six finite numbers inside the limits (:data:`LIMIT_SLACK` slack), and
  ``forward(q)`` must reproduce ``T`` within :data:`POSITION_TOL` and :data:`ORIENTATION_TOL`.
* On straight-line moves (samples ``lin_step`` = 1 cm apart), no joint may move more than
  :data:`MAX_LINE_STEP` from the previous sample (a branch change: wrist flip, elbow flip, 2 pi).

:class:`CheckedIk` applies these checks for the planner and raises
:class:`~kr210_sim.errors.IkFailedError` with which pose and what was wrong; it also times every
call (``time.perf_counter`` around the user's function only). An IK that takes many poses in one
call (:attr:`~kr210_sim.sandbox.user_ik.UserIk.batch`: a ROS-form server, as MoveIt sent it a
planned path) is asked in batches of at most :data:`BATCH` poses (:func:`call_many`), and the
planner asks it for a straight line's samples in one request before it walks the line
(:meth:`CheckedIk.prefetch`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from kr210_sim.errors import IkFailedError, UnreachablePoseError
from kr210_sim.robot.description import ARM_JOINTS
from kr210_sim.robot.kinematics import LIMIT_SLACK, TWO_PI, Kinematics
from kr210_sim.sandbox.user_ik import UserIk, describe_exception, where_raised

FloatArray = npt.NDArray[np.float64]

#: Largest position error of ``forward(q)`` against the requested pose [m]. The pass bar of the
#: exercise; a correct closed form is exact to ~1e-12 m.
POSITION_TOL = 1e-3
#: Largest orientation error [rad]. 1 mrad moves the fingertips (0.15-0.2 m ahead of
#: gripper_link) by 0.15-0.2 mm, well inside the position bar, and still catches every wrong
#: frame convention (those err by tens of mrad or more).
ORIENTATION_TOL = 1e-3
#: Largest joint change between neighbouring straight-line samples (<= 1 cm apart) [rad]. Our
#: IK moves a joint at most 0.017 rad per sample over the lines of 200 cells (published and
#: randomised); a wrist flip moves joints 4 and 6 by about pi, a 2 pi twin by 2 pi, an elbow or
#: shoulder flip by tenths of a radian or more. 0.1 rad leaves a 6x margin for correct answers.
MAX_LINE_STEP = 0.1
#: Largest angle [rad] taken at its 2 pi twin for an IK never sent ``q_ref`` (a ROS-form
#: server's answers to one request of unrelated poses drift by turns when it keeps each close
#: to the previous answer, as it would along MoveIt's paths); past it, rounding is too coarse.
EVERY_TURN = 1e4
#: Most poses one batch asks a batch-taking IK for (MoveIt's requests held tens of poses).
BATCH = 64


# --------------------------------------------------------------------------- judging
@dataclass(frozen=True, slots=True)
class Assessment:
    """What one answer of a user's IK function is worth.

    Attributes:
        q: The answer as six angles [rad] after 2 pi twins were moved into the limits, or None
            when the function raised or returned something that is not six finite numbers.
        error: The exception's text when the function raised (``Type: message``), else "".
        problem: The first reason the answer is unusable, one phrase; "" when it is usable.
        returned_none: True when the function returned None ("unreachable").
        position_error: |p(forward(q)) - p(T)| [m] (NaN without q).
        orientation_error: Rotation angle between forward(q) and T [rad] (NaN without q).
        wrist_centre_error: Distance between the wrist centres of forward(q) and T [m].
        within_limits: q is inside the joint limits (False without q).
        wrapped: Joints (0-based) whose angle was replaced by its 2 pi twin inside the limits.
        max_move: Largest |q - q_ref| over the joints [rad] (NaN without q).
        max_move_joint: Joint (0-based) of ``max_move`` (-1 without q).
        call_time: Wall-clock time of the call [s].
    """

    q: FloatArray | None
    error: str
    problem: str
    returned_none: bool
    position_error: float
    orientation_error: float
    wrist_centre_error: float
    within_limits: bool
    wrapped: tuple[int, ...]
    max_move: float
    max_move_joint: int
    call_time: float

    @property
    def passed(self) -> bool:
        """Usable: six finite angles inside the limits that reproduce the pose."""
        return not self.problem


def call_timed(fn: Callable[..., Any], T: FloatArray, q_ref: FloatArray) -> tuple[Any, float]:
    """Call ``fn(T, q_ref)`` on copies of the inputs; return ``(result or exception, seconds)``.

    ``time.perf_counter`` brackets the call only. Exceptions (and ``SystemExit``) raised by the
    function are returned, not raised; ``KeyboardInterrupt`` propagates.
    """
    T_in, q_in = T.copy(), q_ref.copy()  # the user's code may write into its arguments
    t0 = time.perf_counter()
    try:
        out: Any = fn(T_in, q_in)
    except (Exception, SystemExit) as exc:
        out = exc
    return out, time.perf_counter() - t0


def call_many(
    user: UserIk, poses: Sequence[FloatArray], q_refs: Sequence[FloatArray]
) -> list[tuple[Any, float]]:
    """Every pose's answer (or exception) and time [s], as :func:`call_timed` gives them: pose
    by pose, or, for an IK that takes batches, in requests of at most :data:`BATCH` poses, each
    pose timed at its request's time over its poses. An exception the batch call raises (a
    timeout, a dead process) is the answer of each of its poses; ``KeyboardInterrupt`` and
    other ``BaseException`` propagate."""
    if user.batch is None:
        return [call_timed(user.function, T, q) for T, q in zip(poses, q_refs, strict=True)]
    out: list[tuple[Any, float]] = []
    for i in range(0, len(poses), BATCH):
        chunk = [np.array(T, dtype=np.float64) for T in poses[i : i + BATCH]]
        t0 = time.perf_counter()
        try:
            answers: list[Any] = list(user.batch(chunk))
        except (Exception, SystemExit) as exc:
            answers = [exc] * len(chunk)
        if len(answers) != len(chunk):
            answers = [ValueError(f"{len(answers)} answers to {len(chunk)} poses")] * len(chunk)
        dt = (time.perf_counter() - t0) / max(1, len(chunk))
        out += [(a, dt) for a in answers]
    return out


def _as_angles(raw: Any) -> tuple[FloatArray | None, str]:
    """``raw`` as a (6,) float array, or None and why not.

    Whatever converting raises (a tensor that needs grad raises RuntimeError on ``float()``) is
    the reason, never an exception: the answer is unusable, the run goes on.
    """
    try:
        arr = np.asarray(raw, dtype=np.float64)
    except Exception as exc:
        return None, f"returned {_type_name(raw)}, not six numbers ({_exception_text(exc)})"
    if arr.size != 6 or arr.squeeze().shape != (6,):
        return None, f"returned shape {arr.shape}, not six angles"
    arr = arr.reshape(6).copy()
    bad = [ARM_JOINTS[j] for j in range(6) if not math.isfinite(arr[j])]
    if bad:
        return None, f"returned NaN or inf for {', '.join(bad)}"
    return arr, ""


def _type_name(raw: Any) -> str:
    try:
        return type(raw).__name__
    except Exception:  # pragma: no cover - a metaclass that raises
        return "an object"


def _exception_text(exc: BaseException) -> str:
    """``describe_exception`` for exceptions whose own ``str`` may raise."""
    try:
        return describe_exception(exc)
    except Exception:
        return _type_name(exc)


def into_limits(
    kin: Kinematics, q: FloatArray, q_ref: FloatArray, every: bool = False
) -> tuple[FloatArray, tuple[int, ...]]:
    """Move each angle outside the limits of ``kin``'s robot, but within one turn of them, to its
    2 pi twin inside them (nearest ``q_ref``).

    Angles already inside the limits are kept, and so are angles more than one turn outside
    (``1e300``: its "twin" would be rounding noise). With ``every`` (an IK that was never sent
    ``q_ref``), each angle within :data:`EVERY_TURN` of zero is taken at its twin inside the
    limits nearest ``q_ref``, however many turns away it was. Returns the new angles and the
    joints moved.
    """
    g = kin.geometry
    out = q.copy()
    moved: list[int] = []
    for j in range(6):
        lo, hi = g.lower[j] - LIMIT_SLACK, g.upper[j] + LIMIT_SLACK
        v = float(out[j])
        if every:
            if not abs(v) <= EVERY_TURN:
                continue
        elif lo <= v <= hi or not lo - TWO_PI <= v <= hi + TWO_PI:
            continue
        base = v - TWO_PI * math.floor((v - lo) / TWO_PI)  # the twin in [lo, lo + 2 pi)
        twins = [base + k * TWO_PI for k in range(3) if base + k * TWO_PI <= hi]
        if lo <= v <= hi:
            twins.append(v)  # itself, exactly, where its twin in [lo, lo + 2 pi) is rounded
        if twins:
            twin = min(twins, key=lambda t: (abs(t - float(q_ref[j])), t != v))
            if twin != v:
                out[j] = twin
                moved.append(j)
    return out, tuple(moved)


def _degrees(angle: float) -> str:
    """``angle`` [rad] in degrees, one decimal (three significant digits when huge)."""
    d = math.degrees(angle)
    return f"{d:.1f}" if abs(d) < 1e6 else f"{d:.3g}"


def _rotation_angle(Ra: FloatArray, Rb: FloatArray) -> float:
    """Angle of the rotation between ``Ra`` and ``Rb`` [rad], accurate near 0."""
    # |Ra - Rb|_F = 2 sqrt(2) sin(angle / 2)
    s = float(np.linalg.norm(Ra - Rb)) / (2.0 * math.sqrt(2.0))
    return 2.0 * math.asin(min(1.0, s))


def assess(
    kin: Kinematics,
    T: FloatArray,
    q_ref: FloatArray,
    raw: Any,
    call_time: float = 0.0,
    no_q_ref: bool = False,
) -> Assessment:
    """Judge one answer ``raw`` of a user's IK for pose ``T`` from ``q_ref`` (see module doc).

    Args:
        kin: The kinematics of the robot the answer is for (its limits and forward kinematics).
        T: Requested gripper_link pose (4x4).
        q_ref: Joint state passed to the function [rad].
        raw: What the function returned, or the exception it raised.
        call_time: Wall-clock time of the call [s].
        no_q_ref: The function was never sent ``q_ref`` (a ROS-form server: MoveIt's requests
            held poses only), so each angle is taken at its 2 pi twin nearest ``q_ref``.
    """
    nan = math.nan

    def unusable(problem: str, error: str = "", none: bool = False) -> Assessment:
        return Assessment(None, error, problem, none, nan, nan, nan, False, (), nan, -1, call_time)

    if isinstance(raw, BaseException):
        text = _exception_text(raw) + where_raised(raw)
        return unusable(f"raised {text}", error=text)
    if raw is None:
        return unusable("returned None (unreachable)", none=True)
    q, why = _as_angles(raw)
    if q is None:
        return unusable(why)
    q, wrapped = into_limits(kin, q, q_ref, every=no_q_ref)
    g = kin.geometry
    outside = [
        j for j in range(6) if not (g.lower[j] - LIMIT_SLACK <= q[j] <= g.upper[j] + LIMIT_SLACK)
    ]
    Tq = kin.forward(q)
    pos_err = float(np.linalg.norm(Tq[:3, 3] - T[:3, 3]))
    ori_err = _rotation_angle(Tq[:3, :3], T[:3, :3])
    wc_err = float(np.linalg.norm((Tq[:3, 3] - g.dg * Tq[:3, 0]) - (T[:3, 3] - g.dg * T[:3, 0])))
    move = np.abs(q - q_ref)
    j_move = int(np.argmax(move))
    problem = ""
    if outside:
        j = outside[0]
        problem = (
            f"returned {ARM_JOINTS[j]} = {_degrees(q[j])} deg, outside its limits "
            f"[{math.degrees(g.lower[j]):.0f}, {math.degrees(g.upper[j]):.0f}] deg"
        )
    elif pos_err > POSITION_TOL or ori_err > ORIENTATION_TOL:
        problem = (
            f"returned q {np.round(q, 4).tolist()} that misses the pose by "
            f"{1000 * pos_err:.3g} mm and {1000 * ori_err:.3g} mrad (wrist centre "
            f"{1000 * wc_err:.3g} mm off; allowed {1000 * POSITION_TOL:g} mm, "
            f"{1000 * ORIENTATION_TOL:g} mrad)"
        )
    return Assessment(
        q,
        "",
        problem,
        False,
        pos_err,
        ori_err,
        wc_err,
        not outside,
        wrapped,
        float(move[j_move]),
        j_move,
        call_time,
    )


def branch_change(q: FloatArray, q_ref: FloatArray, threshold: float = MAX_LINE_STEP) -> str:
    """Name the jump from ``q_ref`` to ``q`` when a joint moves more than ``threshold`` [rad].

    Returns "" (no jump), "2pi jump" (every large move is a whole turn), "q4/q6 split" (only
    joints 4 and 6 move, at the wrist singularity q5 = 0, where only q4 + q6 counts), "wrist
    flip" (only joints 4-6 move much) or "arm branch change" (joint 1, 2 or 3 moves much).
    """
    qa = np.asarray(q, dtype=np.float64)
    d = qa - np.asarray(q_ref, dtype=np.float64)
    big = np.flatnonzero(np.abs(d) > threshold)
    if not len(big):
        return ""
    wrapped = np.abs(np.remainder(d[big] + math.pi, TWO_PI) - math.pi)
    if np.all(wrapped <= threshold):
        return "2pi jump"
    if set(big.tolist()) <= {3, 5} and abs(math.sin(qa[4])) < 1e-3:
        return "q4/q6 split"
    if np.all(big >= 3):
        return "wrist flip"
    return "arm branch change"


# --------------------------------------------------------------------------- for the planner
@dataclass
class CallStats:
    """Calls of a user's IK function and their wall-clock times [s]."""

    calls: int = 0
    total: float = 0.0
    max: float = 0.0

    def add(self, seconds: float) -> None:
        """Count one call of ``seconds`` [s]."""
        self.calls += 1
        self.total += seconds
        self.max = max(self.max, seconds)

    @property
    def mean(self) -> float:
        """Mean time per call [s] (0 before the first call)."""
        return self.total / self.calls if self.calls else 0.0


def _pose_text(T: FloatArray) -> str:
    return str(np.round(T[:3, 3], 3).tolist())


class CheckedIk:
    """A user's IK function as the planner calls it: every answer checked, every call timed.

    Args:
        user: The loaded function.
        kin: The kinematics of the robot it solves for (judges its answers).
    """

    def __init__(self, user: UserIk, kin: Kinematics) -> None:
        self.user = user
        self.kin = kin
        self.stats = CallStats()
        self._ahead: dict[bytes, list[tuple[Any, float]]] = {}

    def prefetch(self, poses: Sequence[FloatArray]) -> None:
        """Ask a batch-taking IK for ``poses`` now, in one request (:func:`call_many`), for
        :meth:`solve` to take their answers from when it is asked for those poses (the same
        numbers, bit for bit); nothing for an IK that takes one pose at a time. Answers
        fetched before and not taken are dropped."""
        self._ahead = {}
        if self.user.batch is None or not poses:
            return
        zeros = [np.zeros(6)] * len(poses)
        for T, got in zip(poses, call_many(self.user, poses, zeros), strict=True):
            self._ahead.setdefault(np.asarray(T, dtype=np.float64).tobytes(), []).append(got)

    def solve(
        self, T: FloatArray, q_ref: FloatArray, what: str, max_step: float | None = None
    ) -> FloatArray:
        """The user's answer for ``T`` from ``q_ref``, or an error naming the pose and the fault.

        Args:
            T: Requested gripper_link pose (4x4).
            q_ref: Current (or previous sample's) joint state [rad].
            what: Which pose this is, for the message ("standoff pose", "approach line sample
                3", ...).
            max_step: On straight lines, the largest joint move from ``q_ref`` [rad].

        Raises:
            IkFailedError: When the answer is unusable (see :func:`assess`) or jumps more than
                ``max_step``.
            UnreachablePoseError: When the function returns None and our IK agrees the pose is
                unreachable.
        """
        ahead = self._ahead.get(np.asarray(T, dtype=np.float64).tobytes())
        raw, dt = ahead.pop(0) if ahead else call_timed(self.user.function, T, q_ref)
        self.stats.add(dt)
        a = assess(self.kin, T, q_ref, raw, dt, no_q_ref=self.user.batch is not None)
        where = f"{what} {_pose_text(T)}"
        if a.returned_none:
            try:
                q_ours = self.kin.nearest(T, q_ref)
            except UnreachablePoseError as exc:
                raise UnreachablePoseError(f"{where}: {exc}") from None
            raise IkFailedError(
                f"{where}: {self.user.spec} returned None (unreachable), but the pose is "
                f"reachable, e.g. q = {np.round(q_ours, 3).tolist()}"
            )
        if not a.passed:
            raise IkFailedError(f"{where}: {self.user.spec} {a.problem}")
        assert a.q is not None
        if max_step is not None and a.max_move > max_step:
            kind = branch_change(a.q, q_ref, max_step) or "jump"
            raise IkFailedError(
                f"{where}: {self.user.spec} moves {ARM_JOINTS[a.max_move_joint]} by "
                f"{a.max_move:.2f} rad from the previous sample (limit {max_step} rad per "
                f"sample): {kind}; pick the solution nearest q_ref"
            )
        return a.q

    def line_ik(self, what: str) -> Callable[[FloatArray, FloatArray], FloatArray]:
        """``ik(T, q_prev)`` for :func:`~kr210_sim.plan.trajectory.plan_cartesian_line`: every
        sample
        checked, including the :data:`MAX_LINE_STEP` jump check, and numbered in messages."""
        sample = 0

        def ik(T: FloatArray, q_prev: FloatArray) -> FloatArray:
            nonlocal sample
            sample += 1
            return self.solve(T, q_prev, f"{what} sample {sample}", max_step=MAX_LINE_STEP)

        return ik

    def summary(self) -> dict[str, Any]:
        """The report's ``ik`` block: SPEC, calls and the wall time per call [s]."""
        s = self.stats
        return {
            "spec": self.user.spec,
            "calls": s.calls,
            "wall_time_s": {"per_call_mean": s.mean, "per_call_max": s.max, "total": s.total},
        }
