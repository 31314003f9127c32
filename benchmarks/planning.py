"""Planning in each shipped cell and in cells nobody tuned for: time, checks, cycle time.

Runs ten cycles per cell (seed 0) and prints, side by side in one run: successes, robot-cell
contact ticks, the moves OMPL planned (in brackets those searched: a move planned again from the
same start to the same goal is remembered; then those searched more than once, the first search
of the escalation failing), planning wall and CPU time per cycle (mean / max),
validity checks per OMPL search, the mean cycle time and the moves' duration over their lower
bound (mean per cycle). Then the cost of one validity check, and `check`'s verdict on a cell
where no path exists. The cells nobody tuned for: the column moved to three other places in the
swing, and an obstacle put over the ready pose's fingers.

Run: python benchmarks/planning.py [--quick]   (--quick: three cycles per cell)
"""

from __future__ import annotations

import sys
import time

import mujoco
import numpy as np

from kr210_sim.cell.load import compile_cell, model_for
from kr210_sim.cell.spec import MotionConfig
from kr210_sim.cell.toml import PUBLISHED_CELL, parse_cell
from kr210_sim.plan.cellcheck import check_cell
from kr210_sim.plan.collide import CollisionChecker
from kr210_sim.robot.description import load_robot
from kr210_sim.robot.kinematics import Kinematics
from kr210_sim.score.report import summarise
from kr210_sim.sim.runner import RunConfig, Runner

CELLS = PUBLISHED_CELL.parent
SHIPPED = ("published", "other_side", "grid_4x2", "column", "slalom", "wall")
#: The column cell with its column elsewhere in the swing (centre x, y [m]); at (1.6, 1.6) it is
#: tests/plan/column_by_the_ready_pose.toml, whose slot 6 approach needs the escalation.
MOVED = ((1.3, 1.5), (2.0, 0.55), (0.9, 1.9), (1.6, 1.6))


def _variant(name: str, old: str, new: str) -> mujoco.MjModel:
    text = (CELLS / "column.toml").read_text()
    text = text.replace('name = "column"', f'name = "{name}"').replace(old, new)
    return compile_cell(parse_cell(text))


def cells() -> list[tuple[str, mujoco.MjModel]]:
    """The shipped cells and the untuned variants."""
    out = [(name, model_for(cell=CELLS / f"{name}.toml")) for name in SHIPPED]
    for x, y in MOVED:
        out.append(
            (
                f"column@{x},{y}",
                _variant("moved", "position = [1.8, 1.0, 1.5]", f"position = [{x}, {y}, 1.5]"),
            )
        )
    T = Kinematics(load_robot()).forward(np.array(MotionConfig().ready_q))
    c = T[:3, :3] @ (0.25, 0.0, 0.0) + T[:3, 3]  # round the ready pose's fingers
    blocked = _variant(
        "ready_blocked",
        "position = [1.8, 1.0, 1.5]  # centre\nsize = [0.3, 0.3, 3.0]",
        f"position = [{c[0]:.3f}, {c[1]:.3f}, {c[2]:.3f}]\nsize = [0.3, 0.3, 0.3]",
    )
    out.append(("ready_blocked", blocked))
    return out


def check_cost(model: mujoco.MjModel, n: int = 3000) -> float:
    """Mean cost of one validity check at random joint states [s]."""
    robot = load_robot()
    checker = CollisionChecker(model, Kinematics(robot))
    valid = checker.state_validity()
    qs = np.random.default_rng(0).uniform(robot.q_lower, robot.q_upper, (n, 6))
    t0 = time.perf_counter()
    for q in qs:
        valid(q)
    return (time.perf_counter() - t0) / n


def main() -> None:
    cycles = 3 if "--quick" in sys.argv else 10
    print(
        f"{'cell':<16} {'ok':>6} {'contacts':>8} {'ompl, escalated':>15} {'wall mean / max':>17} "
        f"{'CPU mean / max':>16} {'checks/search':>13} {'cycle s':>7} {'/bound':>6}  ready pose"
    )
    for name, model in cells():
        runner = Runner(RunConfig(cycles=cycles), model=model)
        checker, router = runner.planner.checker, runner.planner.router
        assert checker is not None and router is not None
        checks = 0
        for i in range(1, cycles + 1):
            c0 = checker.checks
            runner.run_cycle(i, runner.slot_for_cycle())
            checks += checker.checks - c0
        s = summarise(runner.results)
        p, c = s["wall_planning_time_s"], s["cpu_planning_time_s"]
        per_plan = checks / router.searches if router.searches else 0.0
        ompl = f"{s['detours']} ({router.searches}) {router.escalated}"
        ratio = s.get("motion_time_over_bound", {"mean": 0.0})["mean"]
        note = "moved clear" if runner.planner.ready_note else "as set"
        print(
            f"{name:<16} {s['successes']:>3}/{cycles:<2} {s['env_contact_ticks']:>8} "
            f"{ompl:>15} {1e3 * p['mean']:>6.0f} / {1e3 * p['max']:>5.0f} ms "
            f"{1e3 * c['mean']:>6.0f} / {1e3 * c['max']:>5.0f} ms {per_plan:>13.0f} "
            f"{s['cycle_time_mean']:>7.2f} {ratio:>6.3f}  {note}"
        )
    cost = check_cost(model_for(cell=CELLS / "column.toml"))
    print(f"one validity check (arm alone, column cell): {1e6 * cost:.1f} us")
    wall = _variant(
        "walled_in", "size = [0.3, 0.3, 3.0]", "size = [0.3, 6.0, 3.0]"
    )  # a wall from y = -2 to 4 at x = 1.8: the shelf is out of every path's reach
    t0 = time.perf_counter()
    result = check_cell(wall)
    took = time.perf_counter() - t0
    row = result.slots[0]
    print(
        f"walled_in: {'served' if result.ok else 'NOT SERVED'} ({took:.1f} s); slot 1: {row.detail}"
    )


if __name__ == "__main__":
    main()
