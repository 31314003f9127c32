"""Sessions of the runner: one episode's setup, and the one loop that runs a run's cycles.

An evaluation episode, its re-run for a recording, the README's pictures and a Gymnasium
episode are all "one cycle of ``RunConfig(cycles=1, seed=seed, ...)`` in a fresh cell":
:func:`episode_runner` builds it, so they draw the same slot and target for the same seed and
plan with the same planner, collision checks and drop spot as ``run``.

``run`` and ``view`` run their cycles through :func:`run_session`: the same cycles in the same
order, each one's line printed as it ends, the same report (:func:`runner_report`). What each
adds is a hook: ``run``'s state recorders and ``view``'s pacer step with the physics
(:attr:`kr210_sim.sim.cell.Cell.hooks`), ``view``'s demo gate waits before every phase of the
cycle plan (:attr:`kr210_sim.sim.runner.Runner.on_phase`); none of them changes the physics.
"""

from __future__ import annotations

import copy
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, TextIO

import numpy as np

from kr210_sim.plan.collide import CollisionChecker
from kr210_sim.robot.description import RobotDescription
from kr210_sim.sandbox.user_ik import UserIk
from kr210_sim.score.report import build_report, cycle_line
from kr210_sim.sim.cell import Cell
from kr210_sim.sim.perceived import PerceiverFactory
from kr210_sim.sim.runner import RunConfig, Runner
from kr210_sim.util.interrupts import check as check_interrupt
from kr210_sim.util.interrupts import signal_name

import mujoco  # isort: skip


def episode_runner(
    seed: int = 0,
    *,
    randomize: bool = False,
    slot: int = 0,
    model: mujoco.MjModel | None = None,
    copy_model: bool = True,
    robot: RobotDescription | None = None,
    ik: UserIk | None = None,
    keep_recordings: bool = False,
    rng: np.random.Generator | None = None,
    checker: CollisionChecker | None = None,
    perceiver: PerceiverFactory | None = None,
) -> Runner:
    """A fresh runner for one cycle of ``RunConfig(cycles=1, seed=seed, slot=slot,
    randomize=randomize, perceive=perceiver is not None)``: the arm at the ready pose, every
    target spare, the bin empty.

    Its first cycle (``runner.run_cycle(1, runner.slot_for_cycle())``) is the episode; it is
    the first cycle of ``run --cycles 1 --seed <seed>`` with the same options.

    Args:
        seed: The episode's seed.
        randomize: Randomise the target (as ``run --randomize``).
        slot: Slot 1..n, or 0 for a slot drawn from the seed.
        model: The cell's model (default: the committed scene, loaded).
        copy_model: Run on a copy of ``model`` (a pristine model stays pristine: the runner
            sets the targets' sizes in the model it runs). False: run on ``model`` itself.
        robot: The robot description (default: the committed URDF).
        ik: A user's IK function to plan with (default: our closed form).
        keep_recordings: Keep the cycle's per-tick recording (for plots).
        rng: The generator the slot and target are drawn from, instead of one seeded with
            ``seed`` (a Gymnasium environment passes its own ``np_random``).
        checker: A collision checker of the model to plan with (default: one built for it).
        perceiver: Makes the perceiver of ``run --perceive``
            (:class:`kr210_sim.sensors.perceiver.Perceiver`): the episode picks from what the
            sensors saw. None: the truth is told.

    Raises:
        ConfigError: A slot outside the cell.
    """
    perceive = perceiver is not None
    config = RunConfig(cycles=1, seed=seed, slot=slot, randomize=randomize, perceive=perceive)
    if model is not None and copy_model:
        model = copy.copy(model)
    return Runner(
        config,
        model=model,
        robot=robot,
        keep_recordings=keep_recordings,
        ik=ik,
        rng=rng,
        checker=checker,
        perceiver=perceiver,
    )


@dataclass(frozen=True, slots=True)
class SessionEnd:
    """How a session's cycles ended.

    Attributes:
        wall_time: Wall-clock time of the cycles (and the closing shot) [s].
        interrupted: The exception that stopped them early (Ctrl-C, SIGTERM, a closed viewer),
            or None when they all ran.
    """

    wall_time: float
    interrupted: BaseException | None


def run_session(
    runner: Runner,
    out: TextIO,
    *,
    hooks: Sequence[Callable[[Cell], None]] = (),
    on_phase: Callable[[str], None] | None = None,
    after: Callable[[int], None] | None = None,
    closing: Callable[[], None] | None = None,
    stops: tuple[type[BaseException], ...] = (KeyboardInterrupt,),
) -> SessionEnd:
    """Run cycles 1 to ``runner.config.cycles`` (each on the slot the run's generator picks),
    writing each one's line to ``out`` as it ends.

    Args:
        runner: A fresh runner.
        out: Where the per-cycle lines go.
        hooks: Step hooks (recorders, a pacer) installed for the session and removed after it.
        on_phase: The runner's ``on_phase`` for the session (a demo gate), cleared after it.
        after: Called with the cycle number after each cycle's line.
        closing: Called after the last cycle, still inside the session (a closing shot).
        stops: Exceptions that end the session early and are returned, not raised.

    Returns:
        The wall time and the interrupt, if any; the runner holds the cycles that finished.
    """
    cycles = runner.config.cycles
    runner.cell.hooks.extend(hooks)
    runner.on_phase = on_phase
    wall0 = time.perf_counter()
    interrupted: BaseException | None = None
    try:
        for i in range(1, cycles + 1):
            check_interrupt()  # a signal whose exception was swallowed (see util.interrupts)
            cycle = runner.run_cycle(i, runner.slot_for_cycle())
            out.write(cycle_line(cycle, cycles) + "\n")
            out.flush()
            if after is not None:
                after(i)
        if closing is not None:
            closing()
    except stops as exc:
        interrupted = exc
    finally:
        for hook in hooks:
            runner.cell.hooks.remove(hook)
        runner.on_phase = None
    return SessionEnd(time.perf_counter() - wall0, interrupted)


def runner_report(
    runner: Runner, wall_time: float, interrupted: BaseException | bool | None
) -> dict[str, Any]:
    """The report of the cycles ``runner`` ran (``run`` and ``view`` alike): its records, events
    and cell, and the user's IK's call figures when one planned them.

    Args:
        runner: The runner after its cycles.
        wall_time: Wall-clock time of the cycles [s].
        interrupted: The interrupt that stopped them (or True), None/False when they all ran.
    """
    report = build_report(
        runner.config,
        runner.results,
        wall_time,
        interrupted=interrupted,
        events=runner.events,
        cell=runner.layout.describe(),
    )
    if runner.planner.user_ik is not None:
        report["summary"]["ik"] = runner.planner.user_ik.summary()
        ros_form = runner.planner.user_ik.user.batch is not None
        branches = runner.planner.ik_branches.summary(len(runner.results), ros_form)
        report["summary"]["ik"]["branches"] = branches
    if runner.layout.ready_q is not None or runner.planner.ready_note:
        # the ready pose the cell asked for, and the one used when that one touches the cell
        report["cell"]["ready_q_deg"] = np.degrees(runner.planner.ready_q).round(3).tolist()
        report["cell"]["ready_note"] = runner.planner.ready_note
    return report


def unstarted_report(config: RunConfig, interrupt: BaseException) -> dict[str, Any]:
    """The report of a run stopped by ``interrupt`` before its first cycle: no cycles, marked
    interrupted (written all the same: a supervisor's SIGTERM during start-up must not leave
    the report of an earlier run in place)."""
    sys.stderr.write(
        f"kr210_sim: interrupted before the first cycle ({signal_name(interrupt)}); "
        "writing a report of no cycles\n"
    )
    return build_report(config, [], 0.0, interrupted=interrupt)
