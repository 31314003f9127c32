"""Video export cost: the bare renderer against the whole pipeline, for the same frames.

Run: ``python benchmarks/video.py [--frames N] [--scene OLD.xml ...]``. Prints figures only. The
states are taken from one simulated cycle (sampled at 30 fps); "bare" renders each state from
the overview camera and discards it; "pipeline" is :class:`kr210_sim.video.FrameRecorder`:
render, hand over to the writer thread, draw the overlay, pipe to ffmpeg (libx264) and finish
the file. Both are timed in the same process, so their ratio is meaningful on a noisy shared
machine even when the absolute figures are not. ``--scene`` adds the bare 640x480 cost per frame
at the default video quality (medium) of other scene files (e.g. an older commit's
``scenes/kr210_cell.xml`` with its meshes: ``git archive REV scenes assets | tar -x -C
/tmp/old``) next to the committed one's, rendering the same states.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import kr210_sim  # noqa: F401  (chooses MUJOCO_GL=egl before mujoco is imported)
from kr210_sim.render import make_renderer, render_frame
from kr210_sim.runner import RunConfig, Runner
from kr210_sim.video import QUALITY, FrameRecorder, VideoSettings, overlay_lines

import mujoco  # isort: skip

SIZES = ((640, 480), (1280, 720))


def states(n: int) -> tuple[Runner, list[mujoco.MjData]]:
    """``n`` snapshots of the cell's state, 1/30 s of simulated time apart, over one cycle."""
    runner = Runner(RunConfig(cycles=1, seed=0, slot=5))
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


def pipeline(
    model: mujoco.MjModel, snaps: list[mujoco.MjData], w: int, h: int, quality: str
) -> float:
    status: dict[str, object] = {"cycle": 1, "cycles": 1, "slot": 5, "phase": "carry"}
    with tempfile.TemporaryDirectory() as tmp:
        settings = VideoSettings(Path(tmp) / "bench.mp4", ("overview",), w, h, quality=quality)
        rec = FrameRecorder(model, settings, lambda: overlay_lines(status, 0.0))
        rec.capture(snaps[0])  # warm up (also starts ffmpeg)
        t = time.perf_counter()
        for d in snaps:
            rec.capture(d)
        rec.close()
        dt = time.perf_counter() - t
    return dt / len(snaps)


def compare(paths: list[str], snaps: list[mujoco.MjData], rounds: int = 5) -> None:
    """Bare 640x480 medium-quality cost per frame of each scene file, the committed one first;
    the scenes take turns for ``rounds`` rounds and the fastest round of each counts (a shared
    machine's load comes and goes)."""
    from kr210_sim.scene import load_model

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
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=120, help="frames per measurement (120)")
    parser.add_argument(
        "--scene", action="append", default=[], help="another scene file to compare (repeat)"
    )
    args = parser.parse_args()
    runner, snaps = states(args.frames)
    model = runner.model
    if args.scene:
        compare(args.scene, snaps)
        return
    print(f"{args.frames} frames from one cycle, overview camera, libx264")
    print("(x264 preset: fast = ultrafast, medium = veryfast)")
    print(f"{'size':>9} {'quality':>20} {'bare ms':>8} {'pipeline ms':>12} {'ratio':>6}")
    for w, h in SIZES:
        for quality in ("fast", "medium"):
            shadows, shadow_size, msaa = QUALITY[quality]
            model.vis.quality.shadowsize = shadow_size
            model.vis.quality.offsamples = msaa
            b = bare(model, snaps, w, h, shadows)
            p = pipeline(model, snaps, w, h, quality)
            label = f"{quality} ({'shadows' if shadows else 'no shadows'})"
            print(f"{w:>5}x{h:<4} {label:>20} {b * 1e3:8.1f} {p * 1e3:12.1f} {p / b:6.2f}")


if __name__ == "__main__":
    main()
