"""Cost of one sensor look at 640x480: MuJoCo's colour and depth renders, the noise model, and
the segmentation render the training samples add, reported apart from perception's CPU.

Run: ``python benchmarks/sensor_look.py [--looks N] [--cell FILE]``. Prints figures only. The
cell (default: ``scenes/cells/cluttered.toml``) is cluttered as at a cycle's start; each look
is timed in wall and CPU time of this process (llvmpipe rasterising on this thread,
``LP_NUM_THREADS=0``, as in a render process), best and median of N, after one warm-up look.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from collections.abc import Callable
from pathlib import Path

os.environ.setdefault("LP_NUM_THREADS", "0")  # read when the first GL context is made

import numpy as np

import kr210_sim  # noqa: F401  (chooses MUJOCO_GL=egl before mujoco is imported)
from kr210_sim.cell.layout import CellLayout, ready_pose
from kr210_sim.cell.load import model_at
from kr210_sim.sensors.noise import MODELS, apply_noise
from kr210_sim.sensors.render import SensorRig
from kr210_sim.sim.cell import Cell
from kr210_sim.sim.clutter import Clutter
from kr210_sim.util.paths import SCENES_DIR

import mujoco  # isort: skip


def _time(fn: Callable[[], object], n: int) -> tuple[float, float, float]:
    """Best wall, median wall and median CPU time of ``fn`` [ms] over ``n`` calls."""
    fn()
    wall, cpu = [], []
    for _ in range(n):
        w0, c0 = time.perf_counter(), time.process_time()
        fn()
        wall.append((time.perf_counter() - w0) * 1e3)
        cpu.append((time.process_time() - c0) * 1e3)
    return min(wall), statistics.median(wall), statistics.median(cpu)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--looks", type=int, default=20)
    parser.add_argument("--cell", type=Path, default=SCENES_DIR / "cells" / "cluttered.toml")
    args = parser.parse_args()
    model = model_at(args.cell)
    cell = Cell(model)
    cell.reset(ready_pose(model))
    layout = CellLayout.from_model(model)
    clutter = Clutter(model, layout)
    clutter.place(cell.data, clutter.draw(np.random.default_rng(0)))
    mujoco.mj_forward(model, cell.data)
    rig = SensorRig(model)
    name = next(s.name for s in rig.sensors.values() if s.mount == "world")
    spec = rig.sensor(name)
    rng = np.random.default_rng(0)
    rgb, depth, _ = rig.render(cell.data, name)
    intr = rig.intrinsics(name)
    model_noise = MODELS[spec.noise if spec.noise != "none" else "d415"]
    rows = [
        ("RGB + depth render", lambda: rig.render(cell.data, name)),
        ("  + segmentation render", lambda: rig.render(cell.data, name, segmentation=True)),
        (
            f"noise model ({model_noise.name})",
            lambda: apply_noise(rgb, depth, intr, model_noise, rng),
        ),
        ("a whole look (render + noise)", lambda: rig.look(cell.data, name, rng)),
        ("a look with labels (samples)", lambda: rig.look_with_truth(cell.data, name, rng)),
    ]
    w, h = spec.resolution
    print(f"sensor {name!r} of {args.cell.name}: {w}x{h}, {args.looks} looks each")
    print(f"{'':34s} {'best wall':>10s} {'median wall':>12s} {'median CPU':>11s}")
    for label, fn in rows:
        best, med, cpu = _time(fn, args.looks)
        print(f"{label:34s} {best:8.1f} ms {med:10.1f} ms {cpu:9.1f} ms")
    rig.close()


if __name__ == "__main__":
    main()
