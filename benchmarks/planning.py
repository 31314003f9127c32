"""Planning time per cycle (collision checks and detours included) in each shipped cell.

Runs ten cycles per cell and prints the planning wall and CPU time per cycle (mean, max), the moves
that needed a detour, successes and robot-cell contact ticks. Run: python benchmarks/planning.py
"""

from __future__ import annotations

from kr210_sim.cell.load import model_for
from kr210_sim.cell.toml import PUBLISHED_CELL
from kr210_sim.score.report import summarise
from kr210_sim.sim.runner import RunConfig, Runner

CELLS = ("published", "other_side", "grid_4x2", "column")


def main() -> None:
    print(
        f"{'cell':<12} {'ok':>6} {'contacts':>8} {'detours':>7} "
        f"{'wall mean / max':>17} {'CPU mean / max':>16}  (planning per cycle)"
    )
    for name in CELLS:
        model = model_for(cell=PUBLISHED_CELL.parent / f"{name}.toml")
        runner = Runner(RunConfig(cycles=10), model=model)
        for i in range(1, 11):
            runner.run_cycle(i, runner.slot_for_cycle())
        s = summarise(runner.results)
        p, c = s["wall_planning_time_s"], s["cpu_planning_time_s"]
        print(
            f"{name:<12} {s['successes']:>3}/10 {s['env_contact_ticks']:>8} {s['detours']:>7} "
            f"{1e3 * p['mean']:>6.1f} / {1e3 * p['max']:>5.1f} ms "
            f"{1e3 * c['mean']:>6.1f} / {1e3 * c['max']:>5.1f} ms"
        )


if __name__ == "__main__":
    main()
