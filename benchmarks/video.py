"""Video cost: render rate with 1 and W processes, the encoder's own rate, and a whole run.

Run: ``python benchmarks/video.py [--workers 2] [--no-runs]``. Prints figures only. Everything is
measured in one run on the same states (one recorded cycle at 30 Hz, 640x480, default quality
``medium``, overview camera), so the ratios are meaningful on a noisy shared machine even when the
absolute figures are not:

* render only, in this process (no encoding): the cost of a frame;
* the encoder alone (overlay + ffmpeg/libx264) fed one rendered frame again and again: the rate
  no number of render processes can pass;
* the render pool with 1 process (render here, encode on a thread) and with W processes, wall
  time from the start (process start-up included) to the finished MP4;
* ``run --cycles 10 --video`` at 640x480, as the user runs it (default: one render process per
  core), with ``--render-workers 1``, and simulate-then-render (``run --record`` then ``replay``).
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import numpy.typing as npt

import kr210_sim  # noqa: F401  (chooses MUJOCO_GL=egl before mujoco is imported)
from kr210_sim.cell.load import load_model
from kr210_sim.media.recording import Recording, StateRecorder, read_recording
from kr210_sim.media.render import draw_level
from kr210_sim.media.render_pool import FrameRenderer, default_workers, render_recording
from kr210_sim.media.video import VideoSettings, _Writer
from kr210_sim.sim.session import episode_runner

import mujoco  # isort: skip

W, H = 640, 480


def one_cycle() -> Recording:
    """One cycle's states at 30 Hz."""
    runner = episode_runner(0, slot=5)
    rec = StateRecorder(runner.model, runner.cell.handles.target_geoms, runner.status, 30)
    runner.cell.hooks.append(rec)
    runner.run_cycle(1, 5)
    return rec.recording({"model_sha256": "", "scene": None})


def drawn_triangles(model: mujoco.MjModel) -> int:
    """Triangles of the mesh geoms drawn by default (groups 0-2)."""
    return sum(
        int(model.mesh_facenum[model.geom_dataid[g]])
        for g in range(model.ngeom)
        if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH and model.geom_group[g] <= 2
    )


def render_only(
    rec: Recording, settings: VideoSettings
) -> tuple[float, list[npt.NDArray[np.uint8]]]:
    """Frames per second of rendering alone, in this process, and the frames."""
    wall, _, frames = _draw_all(rec, settings)
    return rec.frames / wall, frames


def _draw_all(
    rec: Recording, settings: VideoSettings
) -> tuple[float, float, list[npt.NDArray[np.uint8]]]:
    """Draw every frame of ``rec`` (after a warm-up frame): wall and CPU time of this process
    [s], and the frames."""
    r = FrameRenderer(load_model(), settings, rec.target_geoms)
    r.render(rec.arrays["qpos"][0], rec.shapes_at(0), False)  # warm up
    t, c = time.perf_counter(), time.process_time()
    frames = [r._draw(rec.arrays["qpos"][i], rec.shapes_at(i), False) for i in range(rec.frames)]
    wall, used = time.perf_counter() - t, time.process_time() - c
    r.close()
    return wall, used, frames


def encoder_only(
    rec: Recording, settings: VideoSettings, frames: list[npt.NDArray[np.uint8]]
) -> tuple[float, float]:
    """Frames per second of the encoder alone (overlay + libx264) fed the rendered ``frames``,
    and the CPU time a frame costs it (this process and ffmpeg) [s]."""
    writer = _Writer(settings)
    t, c = time.perf_counter(), cpu()
    for i, frame in enumerate(frames):
        writer.put(frame.copy(), rec.status(i).lines())
    writer.close()
    return len(frames) / (time.perf_counter() - t), (cpu() - c) / len(frames)


def _render_alone(n: int, lp_threads: str | None = None) -> float:
    """Render ``n`` frames of the home pose in a fresh process (llvmpipe with ``lp_threads``
    rasteriser threads, its default when None); the seconds it took (after a warm-up frame)."""
    if lp_threads is not None:
        os.environ["LP_NUM_THREADS"] = lp_threads  # read when the GL context is made
    import mujoco
    import numpy as np

    model = load_model()
    settings = VideoSettings(Path("unused.mp4"), ("overview",), W, H, quality="medium")
    r = FrameRenderer(model, settings, np.zeros(0, dtype=np.int32))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    r.render(data.qpos, np.zeros((0, 10)), False)
    t = time.perf_counter()
    for _ in range(n):
        r.render(data.qpos, np.zeros((0, 10)), False)
    return time.perf_counter() - t


def free_cores(workers: int, n: int = 60, lp_threads: str | None = None) -> float:
    """How many times one process's render rate ``workers`` independent render processes reach
    together now (no encoder, no pool): what the machine gives, the most a pool can get. With
    ``lp_threads="0"`` each process rasterises on its own thread (one core each)."""
    import multiprocessing as mp

    with mp.get_context("spawn").Pool(workers) as p:
        p.starmap(_render_alone, [(5, lp_threads)] * workers)  # start every process first
        one = min(p.starmap(_render_alone, [(n, lp_threads)])[0] for _ in range(2))
        many = p.starmap(_render_alone, [(n, lp_threads)] * workers)
    return workers * n / max(many) / (n / one)


def render_cpu(rec: Recording, settings: VideoSettings) -> float:
    """CPU time of one frame rendered on one thread (llvmpipe's own, LP_NUM_THREADS=0), in a
    fresh process [s]."""
    import multiprocessing as mp

    with mp.get_context("spawn").Pool(1) as p:
        return float(p.apply(_frame_cpu, (rec, settings)))


def _frame_cpu(rec: Recording, settings: VideoSettings) -> float:
    os.environ["LP_NUM_THREADS"] = "0"
    return _draw_all(rec, settings)[1] / rec.frames


def cpu() -> float:
    """CPU time of this process and its finished children (render processes, ffmpeg) [s]."""
    me, kids = (
        resource.getrusage(resource.RUSAGE_SELF),
        resource.getrusage(resource.RUSAGE_CHILDREN),
    )
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def pool(rec: Recording, settings: VideoSettings, workers: int) -> tuple[float, ...]:
    """Through the render pool to the finished MP4: frames per second with the start-up, the
    start-up itself (to the first frame written) [s], frames per second after it, and the CPU
    time a frame costs in all processes, start-up included [s]."""
    first: list[float] = []

    def seen(frames: int, sim_time: float) -> None:
        if frames == 1:
            first.append(time.perf_counter())

    t, c = time.perf_counter(), cpu()
    frames, _ = render_recording(rec, load_model(), settings, workers, seen)
    end = time.perf_counter()
    per_frame = (cpu() - c) / frames
    return frames / (end - t), first[0] - t, (frames - 1) / (end - first[0]), per_frame


def wall(argv: list[str], cwd: Path) -> float:
    """Wall time of a ``python -m kr210_sim`` command [s]."""
    t = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "kr210_sim", *argv],
        cwd=cwd,
        check=True,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    return time.perf_counter() - t


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=default_workers(), help="W (cores)")
    parser.add_argument("--no-runs", action="store_true", help="skip the ten-cycle runs")
    args = parser.parse_args()
    rec = one_cycle()
    n = rec.frames
    print(f"{n} frames of one cycle, {W}x{H}, quality medium (shadows), overview, libx264")
    print(f"load average at the start: {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    model = load_model()
    fine, draw = drawn_triangles(model), drawn_triangles(draw_level(model))
    print(f"drawn mesh triangles: {fine:,} (stills, --quality high), {draw:,} (fast, medium)")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        settings = VideoSettings(folder / "bench.mp4", ("overview",), W, H, quality="medium")
        r1, frames_drawn = render_only(rec, settings)
        enc, enc_cpu = encoder_only(rec, settings, frames_drawn)
        del frames_drawn
        frame_cpu = render_cpu(rec, settings)
        p1, s1, f1, c1 = pool(rec, settings, 1)
        pw, sw, fw, cw = pool(rec, settings, args.workers)
        print(f"  render only, this process        {r1:6.1f} frames/s (llvmpipe's own threads)")
        print(f"  render CPU a frame, one thread   {frame_cpu * 1e3:6.1f} ms")
        print(
            f"  encoder alone (overlay + x264)   {enc:6.1f} frames/s, {enc_cpu * 1e3:.1f} ms CPU "
            "a frame"
        )
        print("  render + encode      all frames   after the first   start-up   CPU a frame")
        print(
            f"    1 process          {p1:6.1f}/s     {f1:6.1f}/s       {s1:5.1f} s   "
            f"{c1 * 1e3:6.1f} ms"
        )
        print(
            f"    {args.workers} processes        {pw:6.1f}/s     {fw:6.1f}/s       {sw:5.1f} s   "
            f"{cw * 1e3:6.1f} ms"
        )
        print(
            f"  speed-up with {args.workers}: {pw / p1:.2f}x (all), {fw / f1:.2f}x (after start-up)"
        )
        print(f"  ceiling set by the encoder: {enc / r1:.1f} render processes' worth")
        print(
            f"  {args.workers} independent render processes reach {free_cores(args.workers):.2f}x "
            "one process's rate (render only, the home pose; llvmpipe threads vertex work "
            "poorly, so this moves with the scene and the machine's neighbours)"
        )
        print(
            f"  ... {free_cores(args.workers, lp_threads='0'):.2f}x with one rasteriser thread "
            "each (LP_NUM_THREADS=0): how rendering scales with cores"
        )
        budget = frame_cpu + enc_cpu
        cores = os.cpu_count() or 1
        print(
            f"  CPU a frame, render + encode: {budget * 1e3:.1f} ms -> at best "
            f"{cores / budget:.1f} frames/s on {cores} cores, {cores / budget / f1:.2f}x the "
            "single process: the most any split of the work can reach here"
        )
        if args.no_runs:
            return
        run = ["run", "--cycles", "10", "--report", "r.json", "--video", "v.mp4"]
        t_default = wall(run, folder)
        t_one = wall([*run, "--render-workers", "1"], folder)
        t_fast = wall([*run, "--quality", "fast"], folder)
        t_sim = wall(["run", "--cycles", "10", "--report", "r.json", "--record", "r.npz"], folder)
        t_replay = wall(["replay", "r.npz", "--video", "v2.mp4"], folder)
        frames = len(read_recording(folder / "r.npz").arrays["time"])
        print(f"run --cycles 10 --video v.mp4 (640x480, medium, {frames} frames):")
        print(f"  one render process per core ({default_workers()})  {t_default:6.1f} s")
        print(f"  --render-workers 1                {t_one:6.1f} s")
        print(f"  --quality fast (no shadows)       {t_fast:6.1f} s")
        print(
            f"  simulate, then render: run --record {t_sim:.1f} s + replay {t_replay:.1f} s "
            f"= {t_sim + t_replay:.1f} s"
        )
        print(
            f"  the CPU budget above puts a {frames}-frame video at >= "
            f"{frames * budget / cores:.1f} s on {cores} cores (rendering and encoding only)"
        )
    print(f"load average at the end: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
