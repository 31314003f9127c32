"""Cells nobody tuned for: the column cell's pillar moved over a grid in the swing.

For each position, one cycle per slot (1-9, seed 0) and prints: slots served and run with no
robot-cell contact, the worst cycle's planning CPU time, whether the ready pose had to move
clear, and for every slot that failed its outcome and reason (``no_path`` says what blocks the
radial pick and that no other heading within 45 deg is clear, or why OMPL found no path).

Run: python benchmarks/column_sweep.py
"""

from __future__ import annotations

from kr210_sim.cell.load import compile_cell
from kr210_sim.cell.toml import PUBLISHED_CELL, parse_cell
from kr210_sim.sim.runner import RunConfig, Runner

#: Pillar centres (x, y) [m]: three distances from the base, five bearings across the swing.
POSITIONS = tuple((x, y) for x in (1.0, 1.5, 2.0) for y in (-0.6, 0.0, 0.6, 1.2, 1.8))


def main() -> None:
    text = (PUBLISHED_CELL.parent / "column.toml").read_text()
    print(f"{'column at':<12} {'clear':>5} {'plan CPU max':>12}  ready pose")
    for x, y in POSITIONS:
        moved = text.replace("position = [1.8, 1.0, 1.5]", f"position = [{x}, {y}, 1.5]")
        runner = Runner(RunConfig(cycles=9), model=compile_cell(parse_cell(moved)))
        failed = []
        for slot in range(1, 10):
            r = runner.run_cycle(slot, slot)
            if not r.success or r.env_contact_ticks:
                ticks = r.env_contact_ticks
                failed.append(f"    slot {slot}: {r.reason}, {ticks} contact ticks: {r.detail}")
        worst = max(r.cpu_planning_time for r in runner.results)
        ready = "moved clear" if runner.planner.ready_note else "as set"
        print(f"({x}, {y}){'':<3} {9 - len(failed):>3}/9 {1e3 * worst:>9.0f} ms  {ready}")
        for line in failed:
            print(line[:200])


if __name__ == "__main__":
    main()
