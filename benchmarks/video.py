"""Video export cost: the bare renderer against the whole pipeline, for the same frames.

Run: ``python benchmarks/video.py [--frames N]``. Prints figures only. The states are taken from
one simulated cycle (sampled at 30 fps); "bare" renders each state from the overview camera and
discards it; "pipeline" is :class:`kr210_sim.video.FrameRecorder`: render, hand over to the writer
thread, draw the overlay, pipe to ffmpeg (libx264) and finish the file. Both are timed in the
same process, so their ratio is meaningful on a noisy shared machine even when the absolute
figures are not.
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=120, help="frames per measurement (120)")
    args = parser.parse_args()
    runner, snaps = states(args.frames)
    model = runner.model
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
