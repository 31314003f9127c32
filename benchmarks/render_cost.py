"""Render cost per frame of the committed scene against other scene files, on the same states.

Run: ``python benchmarks/render_cost.py [--frames N] [--scene OLD.xml ...]``. Prints figures
only. The states are taken from one simulated cycle (sampled at 30 fps); each scene renders each
state from the overview camera at 640x480, default video quality (medium), and discards it; the
scenes take turns, best of several rounds, so their ratio is meaningful on a noisy shared machine.
An older look: ``git archive REV scenes assets | tar -x -C /tmp/old`` and ``--scene
/tmp/old/scenes/kr210_cell.xml``.
"""

from __future__ import annotations

import argparse
import time

import kr210_sim  # noqa: F401  (chooses MUJOCO_GL=egl before mujoco is imported)
from kr210_sim.media.render import make_renderer, render_frame
from kr210_sim.media.video import QUALITY
from kr210_sim.sim.runner import Runner
from kr210_sim.sim.session import episode_runner

import mujoco  # isort: skip

SIZES = ((640, 480), (1280, 720))


def states(n: int) -> tuple[Runner, list[mujoco.MjData]]:
    """``n`` snapshots of the cell's state, 1/30 s of simulated time apart, over one cycle."""
    runner = episode_runner(0, slot=5)
    snaps: list[mujoco.MjData] = []

    def grab(cell: object) -> None:
        d = runner.cell.data
        if len(snaps) < n and d.time >= len(snaps) / 30.0:
            snaps.append(mujoco.MjData(runner.model))
            mujoco.mj_copyData(snaps[-1], runner.model, d)

    runner.cell.hooks.append(grab)
    runner.run_cycle(1, 5)
    runner.cell.hooks.remove(grab)
    while len(snaps) < n:  # a short cycle: repeat the states
        snaps.append(snaps[len(snaps) % max(len(snaps), 1)])
    return runner, snaps


def bare(model: mujoco.MjModel, snaps: list[mujoco.MjData], w: int, h: int, shadows: bool) -> float:
    renderer = make_renderer(model, w, h)
    cam = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, "overview")
    render_frame(renderer, snaps[0], cam, shadows)  # warm up
    t = time.perf_counter()
    for d in snaps:
        render_frame(renderer, d, cam, shadows)
    dt = time.perf_counter() - t
    renderer.close()
    return dt / len(snaps)


def compare(paths: list[str], snaps: list[mujoco.MjData], rounds: int = 5) -> None:
    """Bare 640x480 medium-quality cost per frame of each scene file, the committed one first;
    the scenes take turns for ``rounds`` rounds and the fastest round of each counts (a shared
    machine's load comes and goes)."""
    from kr210_sim.cell.load import load_model

    shadows, shadow_size, msaa = QUALITY["medium"]
    scenes = []
    for path in [None, *paths]:
        model = load_model(path)
        model.vis.quality.shadowsize = shadow_size
        model.vis.quality.offsamples = msaa
        moved = []
        for d in snaps:
            m = mujoco.MjData(model)
            m.qpos[:] = d.qpos
            mujoco.mj_forward(model, m)
            moved.append(m)
        scenes.append((path or "committed scene", model, moved))
    best = [float("inf")] * len(scenes)
    for _ in range(rounds):
        for i, (_, model, moved) in enumerate(scenes):
            best[i] = min(best[i], bare(model, moved, 640, 480, shadows) * 1e3)
    print(f"scene comparison: 640x480, medium (default video quality), bare, best of {rounds}")
    for (label, _, _), ms in zip(scenes, best, strict=True):
        print(f"  {ms:6.1f} ms/frame  {ms / best[0]:5.2f}x  {label}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--frames", type=int, default=120, help="frames per measurement (120)")
    parser.add_argument(
        "--scene", action="append", default=[], help="another scene file to compare (repeat)"
    )
    args = parser.parse_args()
    _, snaps = states(args.frames)
    compare(args.scene, snaps)


if __name__ == "__main__":
    main()
