"""How cycles end: success counts and settle times over many seeded ten-cycle runs.

Run: ``python benchmarks/settle.py [--seeds 0:200] [--cells published,column,...] [--out F]``.
Prints figures only (with ``--out``, one JSON line per cycle as well).

For every cell and seed, one ten-cycle run exactly as ``python -m kr210_sim run --cycles 10
--seed S [--cell scenes/cells/<cell>.toml]`` makes it (one process, the model compiled once per
cell). Printed per cell: runs with every cycle a success, cycles, failures by reason, robot-cell
contact ticks; then the settle wait (the ``settle`` phase: from the end of the return move until
the cycle's outcome is decided) as a distribution [s], for cycles that dropped into an empty bin
(the first of a run) and into a fuller one (5-9 cylinders already there).
"""

from __future__ import annotations

import argparse
import json
from collections import Counter
from pathlib import Path

import numpy as np

from kr210_sim.cell.load import model_for
from kr210_sim.cell.toml import PUBLISHED_CELL
from kr210_sim.sim.runner import RunConfig, Runner

CELLS = ("published", "column", "grid_4x2", "other_side")


def _seeds(text: str) -> range:
    lo, _, hi = text.partition(":")
    return range(int(lo), int(hi))


def _stats(values: list[float]) -> str:
    if not values:
        return "-"
    v = np.array(values)
    p50, p95, p99 = np.percentile(v, [50, 95, 99])
    return (
        f"n {len(v):>5}  mean {v.mean():.3f}  p50 {p50:.3f}  p95 {p95:.3f}  p99 {p99:.3f}  "
        f"max {v.max():.3f}"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=_seeds, default=range(0, 200), help="LO:HI (default 0:200)")
    ap.add_argument("--cells", default=",".join(CELLS))
    ap.add_argument("--cycles", type=int, default=10)
    ap.add_argument("--out", type=Path, default=None, help="one JSON line per cycle")
    args = ap.parse_args()
    out = args.out.open("w") if args.out else None
    settle_empty: list[float] = []
    settle_full: list[float] = []
    names = args.cells.split(",")
    perfect: Counter[str] = Counter()
    cycles: Counter[str] = Counter()
    contacts: Counter[str] = Counter()
    failures: dict[str, Counter[str]] = {name: Counter() for name in names}
    failed_seeds: dict[str, list[int]] = {name: [] for name in names}
    for seed in args.seeds:  # seeds outside, cells inside: a cut-short sweep covers every cell
        for name in names:
            cell = None if name == "published" else PUBLISHED_CELL.parent / f"{name}.toml"
            runner = Runner(RunConfig(cycles=args.cycles, seed=seed), model=model_for(None, cell))
            ok = True
            for i in range(1, args.cycles + 1):
                r = runner.run_cycle(i, runner.slot_for_cycle())
                cycles[name] += 1
                contacts[name] += r.env_contact_ticks
                settle = r.phase_times.get("settle", 0.0)
                in_bin = (i - 1) % 10  # the bin is emptied before cycles 11, 21, ...
                if in_bin == 0:
                    settle_empty.append(settle)
                elif in_bin >= 5:
                    settle_full.append(settle)
                if not r.success:
                    ok = False
                    failures[name][str(r.reason)] += 1
                if out is not None:
                    rec = {"cell": name, "seed": seed, "cycle": i, "in_bin": in_bin}
                    rec.update(success=r.success, reason=r.reason, detail=r.detail, settle=settle)
                    rec.update(creep_mm=r.creep_mm, contacts=r.env_contact_ticks)
                    out.write(json.dumps(rec) + "\n")
                    out.flush()
            perfect[name] += ok
            if not ok:
                failed_seeds[name].append(seed)
    for name in names:
        print(
            f"{name:<11} runs {perfect[name]}/{len(args.seeds)} all ok, cycles {cycles[name]}, "
            f"failures {dict(failures[name]) or 'none'}, contact ticks {contacts[name]}, "
            f"failed seeds {failed_seeds[name][:20]}"
        )
    print(f"settle, empty bin [s]: {_stats(settle_empty)}")
    print(f"settle, 5-9 in bin [s]: {_stats(settle_full)}")
    if out is not None:
        out.close()


if __name__ == "__main__":
    main()
