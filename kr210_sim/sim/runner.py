"""The runner: executes and scores pick-and-place cycles in the simulated cell.

Data flow per cycle: spawn a fresh cylinder (config + seeded generator) -> observe its pose ->
plan (:mod:`kr210_sim.plan.planner`) -> execute (:mod:`kr210_sim.sim.cell`) -> monitor -> score
(:mod:`kr210_sim.score.scoring`) -> :class:`CycleResult`.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from kr210_sim.cell.layout import CellLayout
from kr210_sim.cell.load import load_model
from kr210_sim.cell.spec import MotionConfig, TargetSpec
from kr210_sim.errors import ConfigError, IkFailedError, PlanningError, UnreachablePoseError
from kr210_sim.plan.collide import CollisionChecker
from kr210_sim.plan.cycle import CyclePlan, Grip, Move, Step, drop_spot_order
from kr210_sim.plan.landing import landing_blockers, spots_with_room, usable_drop_spots
from kr210_sim.plan.planner import Planner
from kr210_sim.robot.description import RobotDescription, load_robot
from kr210_sim.robot.kinematics import Kinematics
from kr210_sim.sandbox.user_ik import UserIk
from kr210_sim.score.metrics import gripper_tracking_error_mm
from kr210_sim.score.result import CycleResult, Event, TargetSample
from kr210_sim.score.scoring import (
    TOPPLED_TILT_DEG,
    CycleObservation,
    Outcome,
    RestCounter,
    judge,
    outcome_decided,
    plan_failure,
)
from kr210_sim.sim.cell import Cell, TickLog, hold
from kr210_sim.sim.clutter import Clutter
from kr210_sim.sim.perceived import PerceiverFactory, attach, estimate_or, report, rescore
from kr210_sim.sim.targets import TargetPool

import mujoco  # isort: skip

log = logging.getLogger(__name__)
FloatArray = npt.NDArray[np.float64]

#: Time a freshly spawned target is left to settle before it is observed [s].
SPAWN_SETTLE = 0.1
#: Longest wait after the return move for a cycle's outcome to be decided
#: (:func:`kr210_sim.score.scoring.outcome_decided`: the target in the bin for good, or still
#: wherever it lies) [s].
SETTLE_TIMEOUT = 4.0
#: Most cycles one run takes (about 12 h of simulated time, 15 min of wall time); use
#: ``evaluate`` for more.
MAX_CYCLES = 10_000
#: Finger speed below which a closing grip counts as settled [m/s].
GRIP_SETTLED_SPEED = 0.005
#: Largest mismatch between the finger gap and the target diameter for a confirmed grip [m].
GRIP_GAP_TOLERANCE = 0.006
#: Displacement of the target relative to the gripper that counts as lost [m].
LOST_DISTANCE = 0.03
#: Simulated time the arm waits while an event between cycles is shown [s].
EVENT_SHOW = 1.0


@dataclass(frozen=True, slots=True)
class RunConfig:
    """Settings of a run.

    Attributes:
        cycles: Number of pick-and-place cycles.
        seed: Seed of the run's random generator.
        slot: Slot 1..rows x columns of the cell, or 0 for a random slot per cycle.
        randomize: Randomise the target per cycle (see :class:`RandomizationSpec`).
        grasp_attempts: Attempts at a grasp before the cycle is scored ``grasp_missed``.
        motion: Motion settings.
        perceive: Pick from what the sensors saw (:mod:`kr210_sim.sim.perceived`), not the truth.

    The cell (layout, target, randomisation ranges) is the simulated model's
    (:class:`~kr210_sim.cell.layout.CellLayout`), not a setting.
    """

    cycles: int = 10
    seed: int = 0
    slot: int = 0
    randomize: bool = False
    grasp_attempts: int = 2
    motion: MotionConfig = field(default_factory=MotionConfig)
    perceive: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.cycles, int) or not 1 <= self.cycles <= MAX_CYCLES:
            raise ConfigError(
                f"cycles must be a whole number from 1 to {MAX_CYCLES}, got {self.cycles!r} "
                "(use evaluate for more)"
            )
        if not isinstance(self.slot, int) or self.slot < 0:
            raise ConfigError(f"slot must be 0 (random) or a slot number, got {self.slot!r}")
        if self.grasp_attempts < 1:
            raise ConfigError(f"grasp_attempts must be >= 1, got {self.grasp_attempts!r}")


def sample_target(
    rng: np.random.Generator, config: RunConfig, layout: CellLayout, cycle_slot: int
) -> TargetSample:
    """Draw one cycle's target from the run's generator.

    The nominal target sits upright on its board at the slot centre; with ``randomize`` its
    position, yaw, size, mass and friction are drawn from the cell's randomisation ranges.
    """
    r = layout.randomization
    centre = layout.slots[cycle_slot - 1]
    board_top = float(centre[2])
    spec = layout.target
    yaw = 0.0
    offset = np.zeros(2)
    if config.randomize:
        offset = rng.uniform(-r.xy_offset, r.xy_offset, size=2)
        yaw = float(rng.uniform(*r.yaw))
        spec = TargetSpec(
            radius=float(rng.uniform(*r.radius)),
            length=float(rng.uniform(*r.length)),
            mass=float(rng.uniform(*r.mass)),
            friction=float(rng.uniform(*r.friction)),
        )
    position = (
        float(centre[0] + offset[0]),
        float(centre[1] + offset[1]),
        float(board_top + spec.length / 2.0),
    )
    return TargetSample(cycle_slot, position, yaw, spec)


class Runner:
    """Runs cycles in one simulated cell; the cell persists across cycles (the bin fills up).

    Args:
        config: Run settings.
        model: A compiled cell model (default: the committed scene).
        robot: The robot description (default: the committed URDF).
        keep_recordings: Keep every cycle's per-tick :class:`TickLog` in :attr:`recordings`
            (for plots; about 0.9 MB a cycle). Without it memory stays flat however many cycles
            run.
        ik: A user's IK function to plan with (default: our closed form); a cycle whose plan
            meets an unusable answer is scored ``ik_failed``.
        rng: The generator slots and targets are drawn from (default: one seeded with
            ``config.seed``).
        checker: A collision checker of ``model`` to plan with (default: one built for it; a
            Gymnasium environment keeps one for all its episodes).
        perceiver: Makes the perceiver ``config.perceive`` needs
            (:class:`kr210_sim.sensors.perceiver.Perceiver`).
    """

    def __init__(
        self,
        config: RunConfig,
        model: mujoco.MjModel | None = None,
        robot: RobotDescription | None = None,
        keep_recordings: bool = False,
        ik: UserIk | None = None,
        rng: np.random.Generator | None = None,
        checker: CollisionChecker | None = None,
        perceiver: PerceiverFactory | None = None,
    ) -> None:
        self.config = config
        self.robot = robot or load_robot()
        self.model = model if model is not None else load_model()
        self.layout = CellLayout.from_model(self.model)
        if config.slot > self.layout.n_slots:
            raise ConfigError(
                f"slot must be 0 (random) or 1-{self.layout.n_slots} in cell "
                f"{self.layout.name!r}, got {config.slot}"
            )
        self.cell = Cell(self.model)
        #: What stops a cylinder dropped at each drop spot above the bin's floor ("" where
        #: nothing does, :func:`~kr210_sim.plan.landing.landing_blockers`).
        self.landing = landing_blockers(self.model, self.layout, self.cell.handles)
        #: The drop spots cylinders are carried to (0-based): those that reach the floor, or
        #: all when none does (``run`` refuses such a cell before it starts).
        self.drop_spots = usable_drop_spots(self.landing) or tuple(range(len(self.landing)))
        #: Cylinders released over each drop spot since the bin was last emptied: the least
        #: used spots are carried to first (:func:`~kr210_sim.plan.cycle.drop_spot_order`).
        self.dropped = [0] * len(self.landing)
        if checker is None:
            checker = CollisionChecker(self.model, Kinematics(self.robot))
        self.planner = Planner(self.robot, config.motion, ik, checker)
        self.planner.check_ready()
        self.rng = rng if rng is not None else np.random.default_rng(config.seed)
        self.cell.reset(self.planner.ready_q)
        self.q_cmd = self.planner.ready_q.copy()
        self.results: list[CycleResult] = []
        self.keep_recordings = keep_recordings
        self.recordings: list[TickLog] = []
        self.targets = TargetPool(self.cell, self.layout)
        #: The cell's distractors and pick list (nothing happens on a tidy shelf).
        self.clutter = Clutter(self.model, self.layout)
        #: Looks at each cycle's target (``config.perceive``; None: the truth is told).
        self.perceiver = attach(config.perceive, perceiver, self.model, self.planner)
        self.status: dict[str, object] = {
            "cycle": 0,
            "cycles": config.cycles,
            "slot": 0,
            "done": 0,
            "successes": 0,
            "phase": "idle",
            "event": "",
        }
        #: The plan of the cycle running (or last run); None before the first.
        self.plan: CyclePlan | None = None
        #: Called with the phase name before every segment of the cycle's steps runs (the
        #: plan's moves and grip waits, and the moves back after a missed grip; not the spawn
        #: and settle holds around them): a viewer's demo mode blocks in it until the user
        #: presses Next. It must not touch the cell.
        self.on_phase: Callable[[str], None] | None = None

    # -- one cycle -----------------------------------------------------------------------
    def plan_cycle(
        self, position: FloatArray, spec: TargetSpec, q_start: FloatArray | None = None
    ) -> CyclePlan:
        """The whole cycle for the target in play, observed at ``position`` [m]: from
        ``q_start`` [rad] (default: where the arm is commanded now) to the next of
        :attr:`drop_spots` in turn with room (:meth:`drop_spots_with_room`) whose place can
        be planned (:func:`~kr210_sim.plan.cycle.drop_spot_order`).

        Raises:
            UnreachablePoseError, NoPathError, IkFailedError, PlanningError: As
                :meth:`~kr210_sim.plan.planner.Planner.plan_cycle`.
        """
        placed = len(self.targets.in_play) - 1
        room = self.drop_spots_with_room(spec.length)
        # the turn goes over all of drop_spots: a spot with no room does not shift the others'
        order = drop_spot_order(placed, room, self.dropped, self.drop_spots)
        return self.planner.plan_cycle(
            self.q_cmd if q_start is None else q_start,
            position,
            spec,
            self.layout.drop_spots,
            usable=order,  # tried in this order (placed 0, no counts: as given)
        )

    def drop_spots_with_room(self, length: float) -> tuple[int, ...]:
        """The :attr:`drop_spots` where a cylinder ``length`` [m] long, dropped now, comes down
        on the floor or on cylinders lying on their sides, not on one standing (it may topple
        across its neighbours' tops and be thrown out of the bin), and would keep its centre
        below the rim should it tumble onto what stands behind the spot
        (:func:`~kr210_sim.plan.landing.spots_with_room`)."""
        if len(self.targets.in_play) <= 1:  # nothing dropped since the bin was emptied
            return self.drop_spots
        h = self.cell.handles
        return spots_with_room(self.model, self.cell.data, self.layout, h, length, self.drop_spots)

    def _plan_making_room(self, index: int, k: int, spec: TargetSpec) -> CyclePlan:
        """:meth:`plan_cycle` for target ``k``; when no drop spot has room, or the cycle cannot
        be planned while some have none, the bin is emptied first (an event shown before the
        arm moves; target ``k`` stays in its slot) and the cycle planned again: the spots the
        carry reaches may be the full ones.

        Raises:
            UnreachablePoseError, NoPathError, IkFailedError, PlanningError: As
                :meth:`plan_cycle`.
        """
        room = self.drop_spots_with_room(spec.length)
        why = "no drop spot has room for another cylinder"
        if room:
            try:
                return self.plan_cycle(self.observe_target(k), spec)
            except IkFailedError:  # the user's IK is judged as it answered
                raise
            except (UnreachablePoseError, PlanningError):
                if len(room) == len(self.drop_spots):
                    raise
            why = "no drop spot with room for another cylinder could be reached"
        self._show(self.targets.restock(index, keep=k, why=why))
        self.dropped = [0] * len(self.dropped)
        return self.plan_cycle(self.observe_target(k), spec)

    @property
    def events(self) -> list[Event]:
        """What was done to the cylinders between cycles (bin emptied, shelf cleared)."""
        return self.targets.events

    def _spawn(self, sample: TargetSample) -> int:
        """Place a spare target at the sample's pose; return its index. When no spare is left,
        the bin is emptied first: an event, shown for :data:`EVENT_SHOW` s of simulated time."""
        if not self.targets.spare:
            self._show(self.targets.restock(int(self.status["cycle"])))  # type: ignore[call-overload]
            self.dropped = [0] * len(self.dropped)
        return self.targets.spawn(sample.position, sample.yaw, sample.spec)

    def _show(self, event: Event) -> None:
        """Hold the arm still while the overlay names ``event`` (the video shows it)."""
        log.info("before cycle %d: %s", event.before_cycle, event.detail)
        phase = self.status["phase"]
        self.status.update(phase=event.kind.value, event=event.detail)
        self.cell.track(hold(self.q_cmd, EVENT_SHOW), None, event.kind.value)
        self.status.update(phase=phase, event="")

    def observe_target(self, index: int) -> FloatArray:
        """The target's position [m] as the planner perceives it (the simulator's pose: a
        perfect sensor), or with ``perceive`` the cycle's estimate (:attr:`perceiver`)."""
        return estimate_or(self.perceiver, self.cell.target_pose(index)[0])

    def target_tilt_deg(self, index: int) -> float:
        """Angle of target ``index``'s axis from the vertical [deg]."""
        _, R = self.cell.target_pose(index)
        return float(np.degrees(np.arccos(np.clip(abs(R[2, 2]), 0.0, 1.0))))

    def _enter(self, phase: str, step: bool = True) -> None:
        self.status["phase"] = phase
        if step and self.on_phase is not None:
            self.on_phase(phase)

    def _track(self, move: Move, rec: TickLog, phases: dict[str, float]) -> None:
        self._enter(move.phase)
        dt = self.cell.track(move.trajectory, rec, move.phase)
        phases[move.phase] = phases.get(move.phase, 0.0) + dt
        self.q_cmd = move.q_end

    def _hold(
        self,
        seconds: float,
        rec: TickLog | None,
        phase: str,
        phases: dict[str, float],
        until: Callable[[Cell], bool] | None = None,
        step: bool = True,
    ) -> float:
        self._enter(phase, step)
        dt = self.cell.track(hold(self.q_cmd, seconds), rec, phase, until=until)
        phases[phase] = phases.get(phase, 0.0) + dt
        return dt

    def _grip_confirmed(self, radius: float) -> bool:
        cell = self.cell
        right, left = cell.finger_target_contacts()
        gap = self.robot.finger_gap(cell.finger_q)
        return right and left and abs(gap - 2.0 * radius) < GRIP_GAP_TOLERANCE

    def _close(self, radius: float, step: Step, rec: TickLog, phases: dict[str, float]) -> bool:
        """Close the gripper until the grip is confirmed or the step's wait passes."""
        cell = self.cell
        cell.close_gripper()
        settled = 0

        def done(c: Cell) -> bool:
            nonlocal settled
            settled = settled + 1 if abs(c.finger_qd) < GRIP_SETTLED_SPEED else 0
            return settled >= 5 and self._grip_confirmed(radius)

        self._hold(step.wait, rec, step.phase, phases, until=done)
        return self._grip_confirmed(radius)

    def start_cycle(
        self,
        index: int,
        slot: int,
        rec: TickLog | None = None,
        phases: dict[str, float] | None = None,
    ) -> tuple[TargetSample, int]:
        """Start cycle ``index``: draw its target for ``slot``, spawn it and let it settle for
        :data:`SPAWN_SETTLE` s; the target and its index in the pool."""
        sample = sample_target(self.rng, self.config, self.layout, slot)
        sample = self.clutter.dress_target(sample, index)  # the pick list's kind
        self.status.update(cycle=index, slot=slot, phase="spawn")
        k = self._spawn(sample)
        self.clutter.scatter(
            self.cell, k, sample, index, self.rng if self.config.randomize else None
        )
        self._hold(SPAWN_SETTLE, rec, "spawn", {} if phases is None else phases, step=False)
        return sample, k

    def run_cycle(self, index: int, slot: int) -> CycleResult:
        """Run and score one cycle.

        Args:
            index: Cycle number (1-based).
            slot: Slot number (1-based).
        """
        wall0 = time.perf_counter()
        cfg, cell = self.config, self.cell
        rec = TickLog()
        phases: dict[str, float] = {}
        sample, k = self.start_cycle(index, slot, rec, phases)
        t_start = cell.time
        confirmed, held, released = False, False, False
        failure: Outcome | None = None
        failure_message = ""
        tilt = gap = 0.0
        planning = planning_cpu = 0.0
        detours0 = self.planner.detours
        attempts = 0
        grip_ref: FloatArray | None = None
        i_grip = i_release = -1
        spec = sample.spec  # what the plan takes the target to be (with perceive: as seen)
        try:
            if self.perceiver is not None:  # raises NotSeenError: scored before moving
                track = lambda m: self._track(m, rec, phases)  # noqa: E731
                spec = self.perceiver.look(cell, k, sample, self.clutter.kind, self.q_cmd, track)
            while attempts < cfg.grasp_attempts and not confirmed:
                attempts += 1
                # The whole cycle is planned (and collision-checked) before the arm moves.
                shown = cell.time
                plan = self._plan_making_room(index, k, spec)
                t_start += cell.time - shown  # an event shown meanwhile is not the arm's time
                self.plan = plan
                planning += plan.wall_time
                planning_cpu += plan.cpu_time
                for step in plan.steps:
                    if step.move is not None:
                        self._track(step.move, rec, phases)
                    elif step.grip is Grip.CLOSE:
                        confirmed = self._close(sample.spec.radius, step, rec, phases)
                        if not confirmed:
                            break
                        grip_ref = cell.target_in_gripper()
                        i_grip = len(rec)
                    elif step.grip is Grip.OPEN:
                        assert grip_ref is not None
                        lost = float(np.linalg.norm(cell.target_in_gripper() - grip_ref))
                        held = lost < LOST_DISTANCE
                        i_release = len(rec)
                        cell.open_gripper()
                        released = True
                        self._hold(step.wait, rec, step.phase, phases)
                if confirmed:
                    break
                gap = self.robot.finger_gap(cell.finger_q)
                log.info(
                    "cycle %d: grip not confirmed on attempt %d (finger gap %.1f mm)",
                    index,
                    attempts,
                    gap * 1000,
                )
                cell.open_gripper()
                self._hold(0.3, rec, step.phase, phases)
                standoff = self.planner.kinematics.forward(plan.end_of("standoff"))
                self._track(self.planner.lin("retreat", self.q_cmd, standoff), rec, phases)
                tilt = self.target_tilt_deg(k)
                if tilt > TOPPLED_TILT_DEG:  # no upright cylinder left to re-plan for
                    break
            if not confirmed:  # back from the standoff
                self._track(self.planner.plan_return(self.q_cmd), rec, phases)
        except (UnreachablePoseError, PlanningError) as exc:
            failure, failure_message = plan_failure(exc), str(exc)  # no plan: scored before moving
            log.info("cycle %d: %s", index, failure_message)
            if self.q_cmd is not None and not np.allclose(self.q_cmd, self.planner.ready_q):
                try:
                    self._track(self.planner.plan_return(self.q_cmd), rec, phases)
                except PlanningError as back_exc:  # pragma: no cover - defensive
                    log.warning("cycle %d: cannot return to ready: %s", index, back_exc)
            if confirmed and not released:  # do not start the next cycle holding this target
                cell.open_gripper()
        if released and self.plan is not None:
            self.dropped[self.plan.drop_spot] += 1
        cycle_time = cell.time - t_start
        self.status["phase"] = "settle"
        rest = RestCounter(self.model.opt.timestep)
        mass = float(self.model.body_mass[cell.handles.target_bodies[k]])
        in_play = tuple(self.targets.in_play)

        def energy(c: Cell) -> float:
            return sum(c.target_energy(j) for j in in_play)

        def decided(c: Cell) -> bool:  # the outcome can no longer change: stop waiting
            rest.update(c.target_speed(), c.target_spin())
            position = c.target_pose()[0]
            return outcome_decided(position, rest.rested_for, energy(c), mass, self.layout.bin)

        self._hold(SETTLE_TIMEOUT, rec, "settle", phases, until=decided, step=False)
        if not confirmed and tilt <= TOPPLED_TILT_DEG:  # it may have tipped after the last try
            tilt = self.target_tilt_deg(k)
        obs = CycleObservation(
            grasp_confirmed=confirmed,
            held_until_release=held,
            released=released,
            robot_env_contacts=int(sum(int(seg["env_contact"].sum()) for seg in rec.segments)),
            target_position=cell.target_pose(k)[0],
            target_speed=cell.target_speed(k),
            target_spin=cell.target_spin(k),
            rested_for=rest.rested_for,
            target_mass=mass,
            energy=energy(cell),
            plan_failure=failure,
            plan_message=failure_message,
            target_tilt_deg=0.0 if confirmed else tilt,
            grasp_attempts=attempts,
            finger_gap=gap,
            target_radius=sample.spec.radius,
            slot=slot,
            contact_pairs=tuple(sorted(rec.contact_pairs)),
        )
        outcome, detail = judge(obs, self.layout.bin)
        outcome, detail = rescore(self.perceiver, outcome, detail, sample.spec.radius)
        result = self._summarise(
            index,
            sample,
            outcome,
            detail,
            rec,
            cycle_time,
            attempts,
            grip_ref,
            i_grip,
            i_release,
            phases,
            wall0,
            obs,
        )
        moves = () if self.plan is None or failure is not None else self.plan.moves
        result = dataclasses.replace(
            result,
            detours=self.planner.detours - detours0,
            wall_planning_time=planning,
            cpu_planning_time=planning_cpu,
            moves=tuple((m.phase, m.planner, m.trajectory.duration, m.bound) for m in moves),
            perception=report(self.perceiver),
        )
        self.results.append(result)
        if self.keep_recordings:
            self.recordings.append(rec)
        self.status["done"] = len(self.results)
        self.status["successes"] = sum(r.success for r in self.results)
        if index < self.config.cycles:  # no event after the last cycle: none follows
            self._clear_shelf(k, index)
        return result

    def _clear_shelf(self, k: int, index: int) -> None:
        """Take a target left on the shelf after failed cycle ``index`` off it (an event), so the
        slot is free again."""
        pos, _ = self.cell.target_pose(k)
        local = self.layout.shelf.local(pos)
        half = self.layout.shelf.half
        bottom = float(self.layout.slots[:, 2].min())
        near = abs(local[0]) < half[0] + 0.2 and abs(local[1]) < half[1] + 0.2
        if near and pos[2] > bottom - 0.1:
            self._show(self.targets.clear(k, index + 1, f"left there by failed cycle {index}"))

    def _summarise(
        self,
        index: int,
        sample: TargetSample,
        outcome: Outcome,
        detail: str,
        rec: TickLog,
        cycle_time: float,
        attempts: int,
        grip_ref: FloatArray | None,
        i_grip: int,
        i_release: int,
        phases: dict[str, float],
        wall0: float,
        obs: CycleObservation,
    ) -> CycleResult:
        arr = rec.arrays()
        track_deg = np.degrees(np.abs(arr["q"] - arr["q_des"]).max(axis=0))
        grip_err = gripper_tracking_error_mm(self.planner.kinematics, arr["q"], arr["q_des"]).max(
            initial=0.0
        )
        creep = 0.0
        if grip_ref is not None and i_grip >= 0:
            end = i_release if i_release > i_grip else len(arr["t"])
            seg = arr["target_in_gripper"][i_grip:end]
            if len(seg):
                creep = float(np.linalg.norm(seg - grip_ref, axis=1).max() * 1000.0)
        return CycleResult(
            index=index,
            slot=sample.slot,
            success=outcome is Outcome.SUCCESS,
            reason=None if outcome is Outcome.SUCCESS else outcome.value,
            detail=detail,
            cycle_time=round(float(cycle_time), 6),
            max_tracking_error_deg=tuple(round(float(x), 6) for x in track_deg),
            max_gripper_tracking_error_mm=round(float(grip_err), 6),
            creep_mm=round(creep, 6),
            grasp_attempts=attempts,
            env_contact_ticks=obs.robot_env_contacts,
            contact_pairs=tuple(sorted(rec.contact_pairs)),
            target=sample,
            target_final=tuple(round(float(x), 6) for x in obs.target_position),  # type: ignore[arg-type]
            phase_times={k: round(v, 6) for k, v in phases.items()},
            detours=0,
            wall_time=time.perf_counter() - wall0,
            wall_planning_time=0.0,
            cpu_planning_time=0.0,
        )

    def idle(self, seconds: float, phase: str = "done") -> None:
        """Hold the arm where it is for ``seconds`` [s] of simulated time (nothing recorded)."""
        self.status["phase"] = phase
        self.cell.track(hold(self.q_cmd, seconds), None, phase)

    def slot_for_cycle(self) -> int:
        """The slot of the next cycle: fixed, or drawn from the run's generator."""
        if self.config.slot:
            return self.config.slot
        return int(self.rng.integers(1, self.layout.n_slots + 1))
