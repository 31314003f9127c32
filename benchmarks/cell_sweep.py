"""Does ``check`` agree with ``run``? The example cells and cells drawn at random, slot by slot.

For each cell (scenes/cells/*.toml, then ``--cells`` drawn by tests/random_cells.py from seeds
``--seed`` onwards: shelf, bin, obstacles and ready poses of every kind; ``--kind edge``: low and
high shelves, obstacles in front of the shelf, bins near the reach, ready poses facing away with
joint 1 near +-180 deg), ``check`` is asked
which slots it serves and every slot is run ``--rounds`` times in one run (slots in turn, so
the carries go to several drop spots). A slot agrees when check serves it and each of its
cycles succeeds with no robot-cell contact, or check refuses it and none does. Prints one line
per cell with a disagreement, then the figures: cells, slots, agreements, disagreements (each
with check's verdict and run's outcomes and details), and the cells the file's validator
refused on the way.

Run: python benchmarks/cell_sweep.py [--cells 60] [--seed 1000] [--workers 2] [--rounds 2]
[--kind plain|edge] [--no-examples]
(60 cells: about 10 min on two free cores; the seeds from 1000 on were not looked at while the
planner's drop spot and branch choices were made, 0-59 were)
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from random_cells import KINDS, CellAgreement, RandomCell, agreement, random_cell

from kr210_sim.cell.toml import PUBLISHED_CELL


def _one(job: tuple[str, int, str, int, str]) -> tuple[str, CellAgreement | str]:
    name, seed, text, rounds, kind = job
    try:
        cell = random_cell(seed, kind) if not text else RandomCell(seed, text)
    except Exception as exc:  # reported, not raised
        return name, f"no cell: {exc}"
    try:
        return name, agreement(cell, rounds)
    except Exception as exc:  # a crash is a finding too
        return name, f"crashed: {type(exc).__name__}: {exc}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cells", type=int, default=60, help="random cells (60)")
    ap.add_argument("--seed", type=int, default=1000, help="first seed (1000)")
    ap.add_argument("--workers", type=int, default=2, help="processes (2)")
    ap.add_argument("--rounds", type=int, default=2, help="cycles per slot (2)")
    ap.add_argument("--kind", choices=sorted(KINDS), default="plain", help="draw (plain)")
    ap.add_argument("--no-examples", action="store_true", help="random cells only")
    args = ap.parse_args()
    jobs: list[tuple[str, int, str, int, str]] = []
    if not args.no_examples:
        for path in sorted(PUBLISHED_CELL.parent.glob("*.toml")):
            jobs.append((path.stem, 0, path.read_text(), args.rounds, ""))
    prefix = "random" if args.kind == "plain" else args.kind
    for seed in range(args.seed, args.seed + args.cells):
        jobs.append((f"{prefix}_{seed}", seed, "", args.rounds, args.kind))
    t0 = time.perf_counter()
    cells = slots = agree = served = 0
    kinds: Counter[str] = Counter()
    refused_draws: Counter[str] = Counter()
    problems: list[str] = []
    check_s = run_s = 0.0
    slowest: list[tuple[float, str]] = []
    with ProcessPoolExecutor(args.workers) as pool:
        for name, result in pool.map(_one, jobs):
            if isinstance(result, str):
                problems.append(f"{name}: {result}")
                print(f"{name}: {result}", flush=True)
                continue
            cells += 1
            slots += len(result.slots)
            agree += len(result.slots) - len(result.disagreements)
            served += sum(s.served for s in result.slots)
            check_s += result.check_seconds
            run_s += result.run_seconds
            slowest = sorted([*slowest, (result.check_seconds, name)], reverse=True)[:3]
            for why in result.cell.refused:
                refused_draws[why.split(": ", 2)[1] if ": " in why else why] += 1
            for s in result.disagreements:
                kind = "served, run failed" if s.served else "refused, run clean"
                kinds[kind] += 1
                print(f"{name}: {s.describe()}", flush=True)
    print()
    print(f"cells                 {cells} ({len(problems)} more without a result)")
    print(f"slots                 {slots} ({served} served by check, {slots - served} refused)")
    print(f"agreements            {agree}")
    print(f"disagreements         {slots - agree}")
    for kind, n in sorted(kinds.items()):
        print(f"  {kind:<20}{n}")
    print(f"check / run wall time {check_s:.0f} / {run_s:.0f} s (sum over cells)")
    print("slowest checks        " + ", ".join(f"{n} {t:.1f} s" for t, n in slowest))
    print(f"sweep wall time       {time.perf_counter() - t0:.0f} s on {args.workers} workers")
    if refused_draws:
        print("draws the file's validator refused (redrawn):")
        for why, n in refused_draws.most_common():
            print(f"  {n:4d}  {why[:110]}")
    for p in problems:
        print(f"no result: {p}")


if __name__ == "__main__":
    main()
