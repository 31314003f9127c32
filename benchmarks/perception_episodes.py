"""Perceived picks on randomised cluttered shelves: the issue's figures over many episodes.

Run: ``python benchmarks/perception_episodes.py [--episodes N] [--workers W] [--seed S]
[--cell FILE] [--report PATH]``. Runs ``evaluate --perceive --randomize`` on the cluttered cell
(default ``scenes/cells/cluttered.toml``, 1000 episodes, one worker per core) and prints:

- pick success % (with its 95 % Wilson interval) and the failures by reason;
- recognition % (the target seen and the estimate on it);
- the cylinder (target) position error, median / p95 / max [mm], at the cell's default noise;
- the pipeline's CPU time per look'd episode (mean / max) [ms];
- the cycle time (simulated, the wrist camera's second looks included), mean / p50 / p95 [s];
- the wall time per episode (the evaluation's wall time over its episodes, start-up included,
  and the same times the workers: the time one episode takes a worker).

Prints figures only; the report (default: a temporary folder) keeps the failed episodes'
records, each replayed by ``run --cycles 1 --seed <seed> --randomize --perceive --cell FILE``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
from pathlib import Path

from kr210_sim.eval.evaluate import EvalConfig, evaluate
from kr210_sim.util.paths import SCENES_DIR


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=1000)
    parser.add_argument("--workers", type=int, default=len(os.sched_getaffinity(0)))
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--cell", type=Path, default=SCENES_DIR / "cells" / "cluttered.toml")
    parser.add_argument("--report", type=Path, default=None)
    args = parser.parse_args()
    config = EvalConfig(
        episodes=args.episodes,
        seed=args.seed,
        randomize=True,
        workers=args.workers,
        cell=args.cell,
        perceive=True,
    )
    with tempfile.TemporaryDirectory() as tmp:
        report = args.report or Path(tmp) / "perception_episodes.json"
        outcome = evaluate(config, report=report)
        per_look = _cpu_per_look(report.with_name(report.stem + ".episodes.jsonl"))
    s, ex = outcome.report["summary"], outcome.report["wall_execution"]
    p = s["perception"]
    n = s["episodes"]
    lo, hi = s["success_rate_ci95"]
    rlo, rhi = p["recognition_rate_ci95"]
    print(f"cell {args.cell.name}, seed {args.seed}, {n} randomised episodes")
    print(
        f"pick success    {100 * s['success_rate']:.1f} % ({s['successes']}/{n}; "
        f"95 % CI {100 * lo:.1f}-{100 * hi:.1f} %)"
    )
    for reason, f in s["failures"].items():
        seeds = ", ".join(str(e["seed"]) for e in f["examples"][:3])
        print(f"  {reason:<26} {f['count']}  (seeds {seeds})")
    print(
        f"recognition     {100 * p['recognition_rate']:.1f} % ({p['recognised']}/{p['episodes']}; "
        f"95 % CI {100 * rlo:.1f}-{100 * rhi:.1f} %; second looks {p['second_looks']}, "
        f"not seen {p['not_seen']})"
    )
    e = p["position_error_mm"]
    if e is not None:
        print(
            f"cylinder position error  median {e['median']:.2f} mm, p95 {e['p95']:.2f} mm, "
            f"max {e['max']:.2f} mm"
        )
    cpu = p["cpu_time_ms"]
    print(f"pipeline CPU per episode  mean {cpu['mean']:.0f} ms, max {cpu['max']:.0f} ms")
    if per_look:
        print(
            f"pipeline CPU per look (an episode's over its looks)  mean "
            f"{statistics.fmean(per_look):.0f} ms, p95 {_p95(per_look):.0f} ms, "
            f"max {max(per_look):.0f} ms"
        )
    ct = s["cycle_time"]
    print(
        f"cycle time      mean {ct['mean']:.2f} s, p50 {ct['p50']:.2f} s, p95 {ct['p95']:.2f} s "
        "(simulated; second looks included)"
    )
    wall = ex["wall_time_s"]
    print(
        f"wall time       {wall:.0f} s: {wall / n:.2f} s an episode, "
        f"{wall * ex['workers'] / n:.2f} s an episode per worker ({ex['workers']} workers)"
    )


def _cpu_per_look(episodes: Path) -> list[float]:
    """Each perceived episode's pipeline CPU over its looks [ms] (the episodes' file)."""
    out = []
    if episodes.is_file():
        for line in episodes.read_text().splitlines()[1:]:
            p = json.loads(line).get("perception")
            if p and p.get("looks"):
                out.append(p["cpu_time_ms"] / p["looks"])
    return out


def _p95(values: list[float]) -> float:
    return sorted(values)[min(len(values) - 1, round(0.95 * (len(values) - 1)))]


if __name__ == "__main__":
    main()
