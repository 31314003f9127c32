"""Render cost per frame of the committed scene against other scene files, on the same states,
and of the video's draw level of detail step by step.

Run: ``python benchmarks/render_cost.py [--frames N] [--scene OLD.xml ...]``. Prints figures
only. The states are taken from one simulated cycle (sampled at 30 fps); each scene renders each
state from the overview camera at 640x480, default video quality (medium), and discards it; the
scenes take turns, best of several rounds, so their ratio is meaningful on a noisy shared machine.
The levels of detail are compared the same way, drawn as the video draws them (shadows only from
the casters, :class:`kr210_sim.media.render_pool.FrameRenderer`), CPU time of this process with
llvmpipe rasterising on this thread (``LP_NUM_THREADS=0``, as in a render process).
An older look: ``git archive REV scenes assets | tar -x -C /tmp/old`` and ``--scene
/tmp/old/scenes/kr210_cell.xml``.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("LP_NUM_THREADS", "0")  # read when the first GL context is made

import kr210_sim  # noqa: F401  (chooses MUJOCO_GL=egl before mujoco is imported)
from kr210_sim.media.render import (
    DRAW_BUILTINS,
    DRAW_SUFFIX,
    draw_level,
    limit_shadows,
    make_renderer,
    render_frame,
    shadow_casters,
)
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


def _posed(model: mujoco.MjModel, snaps: list[mujoco.MjData]) -> list[mujoco.MjData]:
    """The states ``snaps`` (their joint positions) in ``model``, forward-computed."""
    moved = []
    for d in snaps:
        m = mujoco.MjData(model)
        m.qpos[:] = d.qpos
        mujoco.mj_forward(model, m)
        moved.append(m)
    return moved


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
        scenes.append((path or "committed scene", model, _posed(model, snaps)))
    best = [float("inf")] * len(scenes)
    for _ in range(rounds):
        for i, (_, model, moved) in enumerate(scenes):
            best[i] = min(best[i], bare(model, moved, 640, 480, shadows) * 1e3)
    print(f"scene comparison: 640x480, medium (default video quality), bare, best of {rounds}")
    for (label, _, _), ms in zip(scenes, best, strict=True):
        print(f"  {ms:6.1f} ms/frame  {ms / best[0]:5.2f}x  {label}")


def level_models() -> list[tuple[str, mujoco.MjModel]]:
    """The committed scene at each step of the draw level: fine (stills), the robot's draw
    meshes, + textures as their mean colour, + coarser built-in shapes (the video's level)."""
    from kr210_sim.cell.load import load_model

    fine = load_model()
    video = draw_level(fine)
    meshes = draw_level(fine)  # undo the later steps on a copy
    for m in range(fine.nmat):
        meshes.mat_rgba[m] = fine.mat_rgba[m]
        meshes.mat_texid[m] = fine.mat_texid[m]
    q, vq = fine.vis.quality, meshes.vis.quality
    vq.numslices, vq.numstacks, vq.numquads = q.numslices, q.numstacks, q.numquads
    textures = draw_level(fine)
    tq = textures.vis.quality
    tq.numslices, tq.numstacks, tq.numquads = q.numslices, q.numstacks, q.numquads
    slices = ", ".join(str(v) for v in DRAW_BUILTINS)
    return [
        ("fine (stills, --quality high's meshes)", fine),
        (f"robot's *{DRAW_SUFFIX} meshes", meshes),
        (" + textures as their mean colour", textures),
        (f" + built-ins at {slices} (the video now)", video),
    ]


def levels(snaps: list[mujoco.MjData], rounds: int = 5) -> None:
    """CPU a frame of each draw level on the same states, medium quality as the video draws it;
    the levels take turns, the fastest round of each counts."""
    shadows, shadow_size, msaa = QUALITY["medium"]
    cases = []
    for label, model in level_models():
        model.vis.quality.shadowsize = shadow_size
        model.vis.quality.offsamples = msaa
        renderer = make_renderer(model, 640, 480)
        cases.append((label, renderer, _posed(model, snaps), shadow_casters(model)))
    cam = "overview"
    best = [float("inf")] * len(cases)
    for _ in range(rounds):
        for i, (_, renderer, moved, casters) in enumerate(cases):
            t = time.process_time()
            for d in moved:
                renderer.update_scene(d, camera=cam)
                renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = shadows
                limit_shadows(renderer.scene, casters)
                renderer.render()
            best[i] = min(best[i], (time.process_time() - t) / len(moved) * 1e3)
    print(f"draw levels: 640x480, medium, as the video draws, CPU a frame, best of {rounds}")
    for (label, renderer, _, _), ms in zip(cases, best, strict=True):
        print(f"  {ms:6.1f} ms/frame  {ms / best[0]:5.2f}x  {label}")
        renderer.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--frames", type=int, default=120, help="frames per measurement (120)")
    parser.add_argument(
        "--scene", action="append", default=[], help="another scene file to compare (repeat)"
    )
    args = parser.parse_args()
    _, snaps = states(args.frames)
    levels(snaps)
    compare(args.scene, snaps)


if __name__ == "__main__":
    main()
