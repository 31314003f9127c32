"""The main job's speed: ten headless cycles, real-time factor, and where the time goes.

Run: ``python benchmarks/run.py [--cycles N] [--seed S]``. Prints figures only. The time shares
come from wrapping the hot functions with timers in the same run (IK = ``kinematics.nearest``,
planning = trajectory construction, sampling = ``sample_many``, physics = ``mujoco.mj_step``;
bookkeeping is the rest of the control loop and the runner).
"""

from __future__ import annotations

import argparse
import time
from collections import defaultdict
from collections.abc import Callable
from typing import Any

import mujoco

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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--cycles", type=int, default=10)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()

    # Plain run first: the headline figures, without timer overhead.
    runner = Runner(RunConfig(cycles=args.cycles, seed=args.seed))
    t = time.perf_counter()
    for i in range(1, args.cycles + 1):
        runner.run_cycle(i, runner.slot_for_cycle())
    wall = time.perf_counter() - t
    sim = runner.cell.time
    steps = round(sim / runner.model.opt.timestep)
    ok = sum(r.success for r in runner.results)
    print(f"cycles             : {args.cycles} ({ok} succeeded)")
    print(f"simulated time     : {sim:8.2f} s ({steps:,} physics steps)")
    print(f"wall time          : {wall:8.2f} s")
    print(f"real-time factor   : {sim / wall:8.1f} x")
    print(f"steps per second   : {steps / wall:10,.0f} (whole loop)")

    # Instrumented run: where the time goes.
    task.kinematics.nearest = timed("IK (nearest)", task.kinematics.nearest)  # type: ignore[method-assign]
    task.plan_ptp = timed("trajectory planning", task.plan_ptp)  # type: ignore[assignment]
    line = task.plan_cartesian_line
    task.plan_cartesian_line = timed("trajectory planning", line)  # type: ignore[assignment]
    for cls in (trajectory.PtpTrajectory, trajectory.LineTrajectory, control._Hold):
        cls.sample_many = timed("trajectory sampling", cls.sample_many)  # type: ignore[method-assign]
    control.mujoco.mj_step = timed("physics (mj_step)", mujoco.mj_step)  # type: ignore[attr-defined]
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
    rate = CALLS["physics (mj_step)"] / TIMES["physics (mj_step)"]
    print(f"physics alone      : {rate:10,.0f} steps/s")


if __name__ == "__main__":
    main()
