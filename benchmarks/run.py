"""The main job's speed: ten headless cycles, real-time factor, and where the time goes.

Run: ``python benchmarks/run.py [--cycles N] [--seed S] [--repeat R]``. Prints figures only.

* Headline: the best of ``--repeat`` plain runs (no timers), as wall time and as CPU time of this
  process (the CPU figure is the one to compare on a shared machine: other processes do not
  inflate it).
* Shares: one instrumented run wraps the hot functions with timers (IK = ``Kinematics.nearest``,
  planning = trajectory construction, sampling = ``sample_many``, physics = ``mujoco.mj_step``;
  bookkeeping is the rest of the control loop and the runner).
* Overhead: the control loop (``Cell.track``) and the whole run against ``mj_step`` alone for the
  same steps (the sum of the timed ``mj_step`` calls): the issue's target is a loop at most 1.3x
  the bare physics.
* Physics by tick kind: a third run reads MuJoCo's own timers around every step and splits the
  cost of a step by what touches what (the arm moving with nothing in contact, the fingers
  gripping a part, other contacts such as a part settling in the bin) and by stage (collision
  broad and narrow phase, constraint solver, the rest). Its last line is the ceiling the physics
  sets: the real-time factor of a run whose every step cost as little as the cheapest kind.
"""

from __future__ import annotations

import argparse
import time
from collections import defaultdict
from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np

import kr210_sim.plan.collide as collide
import kr210_sim.plan.planner as task
import kr210_sim.plan.trajectory as trajectory
import kr210_sim.sim.cell as control
from kr210_sim.sim.runner import RunConfig, Runner

TIMES: dict[str, float] = defaultdict(float)
CALLS: dict[str, int] = defaultdict(int)


def timed(name: str, fn: Callable[..., Any]) -> Callable[..., Any]:
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        t = time.perf_counter()
        try:
            return fn(*args, **kwargs)
        finally:
            TIMES[name] += time.perf_counter() - t
            CALLS[name] += 1

    return wrapper


def plain_run(cycles: int, seed: int) -> tuple[float, float, float, int, int]:
    """One untimed run: wall [s], CPU [s], simulated cycle time [s], physics steps, successes."""
    runner = Runner(RunConfig(cycles=cycles, seed=seed))
    t, c = time.perf_counter(), time.process_time()
    for i in range(1, cycles + 1):
        runner.run_cycle(i, runner.slot_for_cycle())
    wall, cpu = time.perf_counter() - t, time.process_time() - c
    sim = sum(r.cycle_time for r in runner.results)
    steps = round(runner.cell.time / runner.model.opt.timestep)
    return wall, cpu, sim, steps, sum(r.success for r in runner.results)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--cycles", type=int, default=10)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--repeat", type=int, default=3, help="plain runs; the best counts (3)")
    args = parser.parse_args()

    runs = [plain_run(args.cycles, args.seed) for _ in range(max(1, args.repeat))]
    wall = min(r[0] for r in runs)
    cpu = min(r[1] for r in runs)
    _, _, sim, steps, ok = runs[0]
    print(f"cycles             : {args.cycles} ({ok} succeeded)")
    print(f"simulated time     : {sim:8.2f} s of cycles ({steps:,} physics steps in all)")
    print(f"wall time (best/{len(runs)}) : {wall:8.2f} s   real-time factor {sim / wall:6.1f} x")
    print(f"CPU time  (best/{len(runs)}) : {cpu:8.2f} s   real-time factor {sim / cpu:6.1f} x")
    print(f"steps per second   : {steps / cpu:10,.0f} (whole loop, CPU time)")

    # Instrumented run: where the time goes.
    nearest = task.Kinematics.nearest
    task.Kinematics.nearest = timed("IK (nearest)", nearest)  # type: ignore[method-assign]
    task.plan_ptp = timed("trajectory planning", task.plan_ptp)  # type: ignore[assignment]
    line = task.plan_cartesian_line
    task.plan_cartesian_line = timed("trajectory planning", line)  # type: ignore[assignment]
    for cls in (trajectory.PtpTrajectory, trajectory.LineTrajectory, control._Hold):
        cls.sample_many = timed("trajectory sampling", cls.sample_many)  # type: ignore[method-assign]
    first_hit = collide.CollisionChecker.first_hit
    collide.CollisionChecker.first_hit = timed("planner collision checks", first_hit)  # type: ignore[method-assign]
    control.mujoco.mj_step = timed("physics (mj_step)", mujoco.mj_step)  # type: ignore[attr-defined]
    loop: dict[str, float] = defaultdict(float)
    track = control.Cell.track

    def timed_track(*a: Any, **k: Any) -> float:
        t = time.perf_counter()
        try:
            return track(*a, **k)
        finally:
            loop["track"] += time.perf_counter() - t

    control.Cell.track = timed_track  # type: ignore[method-assign]
    runner = Runner(RunConfig(cycles=args.cycles, seed=args.seed))
    t = time.perf_counter()
    for i in range(1, args.cycles + 1):
        runner.run_cycle(i, runner.slot_for_cycle())
    total = time.perf_counter() - t
    # planning time includes its IK calls; report IK separately and planning without it
    TIMES["trajectory planning"] -= TIMES["IK (nearest)"]
    TIMES["bookkeeping (loop, runner, monitors)"] = total - sum(TIMES.values())
    print(f"time shares (instrumented run, {total:.2f} s):")
    for name, secs in sorted(TIMES.items(), key=lambda kv: -kv[1]):
        calls = f"{CALLS[name]:,} calls" if name in CALLS else ""
        print(f"  {name:38s} {100 * secs / total:5.1f} %  {secs:6.3f} s  {calls}")
    n_step, physics = CALLS["physics (mj_step)"], TIMES["physics (mj_step)"]
    in_loop = loop["track"] - TIMES["trajectory sampling"]
    a_step = 1e6 * physics / n_step
    print(f"physics alone      : {n_step / physics:10,.0f} steps/s ({a_step:.1f} us a step)")
    print(
        f"control loop       : {in_loop / physics:6.2f} x mj_step alone for the same steps "
        f"({1e6 * (in_loop - physics) / n_step:.1f} us of Python a tick; target <= 1.3 x)"
    )
    print(
        f"whole run          : {total / physics:6.2f} x mj_step alone (planning and sampling too)"
    )
    physics_by_kind(args.cycles, args.seed)


STAGES = (
    ("collision, broad phase", mujoco.mjtTimer.mjTIMER_COL_BROAD),
    ("collision, narrow phase", mujoco.mjtTimer.mjTIMER_COL_NARROW),
    ("constraint solver", mujoco.mjtTimer.mjTIMER_CONSTRAINT),
)
KINDS = ("arm alone, no contact", "fingers gripping a part", "other contacts")


def _tick_kind(model: mujoco.MjModel, data: mujoco.MjData, fingers: frozenset[int]) -> int:
    """0: nothing in contact, 1: a finger geom touches something, 2: other contacts only."""
    if data.ncon == 0:
        return 0
    geoms = data.contact.geom[: data.ncon]
    return 1 if any(int(g) in fingers for g in geoms.ravel()) else 2


def physics_by_kind(cycles: int, seed: int) -> None:
    """Print where ``mj_step`` spends its time, split by tick kind and stage (MuJoCo's timers)."""
    runner = Runner(RunConfig(cycles=cycles, seed=seed))
    model, data = runner.model, runner.cell.data
    fingers = frozenset(
        g
        for g in range(model.ngeom)
        if "finger" in (mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or "")
    )
    timers = [data.timer[mujoco.mjtTimer.mjTIMER_STEP]] + [data.timer[t] for _, t in STAGES]
    cost = np.zeros((len(KINDS), len(timers)))
    ticks = np.zeros(len(KINDS), dtype=int)
    step = mujoco.mj_step

    def counted(m: mujoco.MjModel, d: mujoco.MjData, nstep: int = 1) -> None:
        before = [t.duration for t in timers]
        step(m, d, nstep)
        kind = _tick_kind(m, d, fingers)
        cost[kind] += [t.duration - b for t, b in zip(timers, before, strict=True)]
        ticks[kind] += 1

    control.mujoco.mj_step = counted  # type: ignore[attr-defined]
    try:
        for i in range(1, cycles + 1):
            runner.run_cycle(i, runner.slot_for_cycle())
    finally:
        control.mujoco.mj_step = step  # type: ignore[attr-defined]
    sim = sum(r.cycle_time for r in runner.results)
    total = cost[:, 0].sum()
    print(f"physics by tick kind (MuJoCo's timers, {total:.2f} s in mj_step):")
    header = "".join(f"{name:>25s}" for name, _ in STAGES)
    print(f"  {'kind':26s} {'ticks':>7s} {'share':>6s} {'us/step':>8s}{header}")
    for k, name in enumerate(KINDS):
        if ticks[k] == 0:
            continue
        per = 1e6 * cost[k] / ticks[k]
        stages = "".join(f"{v:25.1f}" for v in per[1:])
        print(f"  {name:26s} {ticks[k]:7,d} {100 * cost[k, 0] / total:5.1f}% {per[0]:8.1f}{stages}")
    cheapest = min(cost[k, 0] / ticks[k] for k in range(len(KINDS)) if ticks[k])
    ceiling = sim / (cheapest * ticks.sum())
    print(f"physics ceiling    : {sim / total:6.1f} x real time for mj_step alone as it runs")
    cheap = f"{1e6 * cheapest:.1f} us (the cheapest kind)"
    print(f"                     {ceiling:6.1f} x if every step cost {cheap}")


if __name__ == "__main__":
    main()
