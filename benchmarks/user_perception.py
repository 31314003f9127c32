"""Bring your own perception: what the jail costs a look, and what the worked example gets.

Run: ``python benchmarks/user_perception.py [--looks N] [--no-jail] [--cycles C] [--randomize]``.
Prints:

- the round trip of one 640 x 480 RGB-D look (2.1 MB: the images' raw bytes after one wire
  frame) to a function that returns at once, in its sandbox (jailed unless ``--no-jail``):
  median / p95 / max [ms] over ``--looks`` looks, after a warm-up look;
- the same look to ``examples/perception_simple.py``: its CPU time in the sandbox (what the
  report's ``cpu_time_ms`` gives) and the round trip [ms];
- ``run --perceive --perception examples/perception_simple.py:perceive`` on the cluttered cell
  for ``--cycles`` cycles (``--randomize``: targets of random size and place): successes, the
  position error median / p95 / max [mm], the wall time.
"""

from __future__ import annotations

import argparse
import io
import tempfile
import time
from pathlib import Path

import numpy as np

from kr210_sim.sandbox.perception_sandbox import open_perception

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "perception_simple.py"
CLUTTERED = ROOT / "scenes" / "cells" / "cluttered.toml"


def _look() -> tuple[dict[str, object], dict[str, np.ndarray]]:
    """A 640 x 480 look at nothing in particular, with the contract's items."""
    rng = np.random.default_rng(0)
    rgb = rng.integers(0, 255, (480, 640, 3), dtype=np.uint8)
    depth = rng.uniform(0.5, 3.0, (480, 640)).astype(np.float32)
    kinds = {"target": {"shape": "cylinder", "size": [0.05, 0.25], "rgb": [0.1, 0.35, 0.95]}}
    items = {
        "sensor": "shelf_rgbd",
        "time": 0.0,
        "K": [[492.0, 0.0, 319.5], [0.0, 492.0, 239.5], [0.0, 0.0, 1.0]],
        "T_base_camera": np.eye(4).tolist(),
        "pick": "target",
        "pick_list": ["target"],
        "kinds": kinds,
        "bay": {"center": [2.69, 0.0, 1.0], "yaw": 0.0, "half": [0.2, 0.4, 0.3]},
    }
    return items, {"rgb": rgb, "depth": depth}


def _times(spec: str, looks: int, jail: bool) -> tuple[list[float], list[float]]:
    """Round trips [ms] and the function's CPU times [ms] of ``looks`` looks."""
    box = open_perception(spec, 30.0, jail=jail)
    items, arrays = _look()
    box.look(items, arrays)  # warm-up: the first look pays the imports
    trips, cpus = [], []
    for _ in range(looks):
        t0 = time.perf_counter()
        got = box.look(items, arrays)
        trips.append((time.perf_counter() - t0) * 1000.0)
        cpus.append(float(got.get("cpu", 0.0)) * 1000.0)
    box.close()
    return trips, cpus


def _figures(xs: list[float]) -> str:
    a = np.asarray(xs)
    return f"{np.median(a):.1f} / {np.percentile(a, 95):.1f} / {a.max():.1f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--looks", type=int, default=30)
    parser.add_argument("--cycles", type=int, default=10)
    parser.add_argument("--no-jail", action="store_true")
    parser.add_argument("--randomize", action="store_true", help="randomise the run's targets")
    args = parser.parse_args()
    jail = not args.no_jail
    with tempfile.TemporaryDirectory() as tmp:
        nothing = Path(tmp) / "nothing.py"
        nothing.write_text("def perceive(look):\n    return []\n")
        trips, _ = _times(f"{nothing}:perceive", args.looks, jail)
        where = "jailed" if jail else "unjailed"
        print(f"round trip of a 640x480 look, {where} (median / p95 / max): {_figures(trips)} ms")
        trips, cpus = _times(f"{EXAMPLE}:perceive", args.looks, jail)
        print(f"examples/perception_simple.py CPU per look: {_figures(cpus)} ms")
        print(f"examples/perception_simple.py round trip:   {_figures(trips)} ms")
        from kr210_sim.api import run

        t0 = time.perf_counter()
        report = run(
            args.cycles,
            cell=CLUTTERED,
            randomize=args.randomize,
            perceive=True,
            perception=f"{EXAMPLE}:perceive",
            out=io.StringIO(),  # the per-cycle lines: not printed
        )
        wall = time.perf_counter() - t0
    s = report.summary
    e = s["perception"]["position_error_mm"]
    print(
        f"run --perceive{' --randomize' * args.randomize} --perception, cluttered, "
        f"{args.cycles} cycles: "
        f"{s['successes']}/{s['cycles']} picked, recognised {s['perception']['recognised']}, "
        f"error median / p95 / max {e['median']:.1f} / {e['p95']:.1f} / {e['max']:.1f} mm, "
        f"{wall:.1f} s wall"
    )


if __name__ == "__main__":
    main()
