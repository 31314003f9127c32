"""Rendering recorded states to MP4, in parallel: W processes render, one encoder writes in order.

Frames are cut into chunks of consecutive frames (:func:`chunk_frames`: up to 8, fewer for big
frames so a worker's buffer stays near 32 MB); chunk ``c`` goes to worker ``c mod W``. Each worker
is a ``spawn``-ed process with its own model (loaded from the parent's, saved as MJB) and its own
OpenGL context; it renders its chunks frame by frame into a chunk's worth of slots in shared
memory (the parent's; a pipe carries one byte a frame to say it is there, and a semaphore the
slots the parent has copied out), keeping at most one chunk of frames ahead: piping the pixels
themselves cost 3-4 ms of CPU a frame, a fifth of drawing one. The parent reads the frames in
order (chunk 0 from worker 0, chunk 1 from worker 1, ...), and the encoder
(:class:`kr210_sim.media.video._Writer`: the overlay, then ffmpeg) writes them as they come:
streaming, with memory bounded by ``W x (2 chunks of states + 1 chunk of frames)`` whatever the
length of the video.

With one worker nothing is spawned: frames are rendered in this process (the reference the
parallel frames are tested against: they are identical, pixel for pixel). A frame whose state is
within :data:`HOLD` of the last one drawn is not drawn again: its pixels are reused.

The parent feeds frames as they are produced (:meth:`RenderPool.feed`): during a run, from the
state recorder's step hook, so rendering overlaps the simulation (the simulation waits when the
workers are two chunks behind); for ``replay``, from a recording. Ctrl-C or SIGTERM: workers
ignore Ctrl-C (the parent blocks SIGINT while it starts them, and they inherit the mask) and are
killed and joined by :meth:`RenderPool.abort`; the encoder then closes the file with the frames
written so far, all consecutive from the first: a playable, shorter MP4.
"""

from __future__ import annotations

import collections
import contextlib
import logging
import math
import os
import signal
import tempfile
import time
from collections.abc import Callable
from dataclasses import asdict
from multiprocessing import shared_memory
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from kr210_sim.errors import RenderError
from kr210_sim.media.recording import FrameStatus, Recording, apply_frame
from kr210_sim.media.render import (
    check_camera,
    check_frame_size,
    draw_level,
    limit_shadows,
    make_renderer,
    shadow_casters,
)
from kr210_sim.media.seen import SeenMarker
from kr210_sim.media.video import QUALITY, VideoSettings, _Writer
from kr210_sim.util.interrupts import deferred

import mujoco  # isort: skip

log = logging.getLogger(__name__)
FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.signedinteger]

#: Largest change of any position coordinate from the last frame drawn [m or rad; quaternion
#: components] below which :meth:`RenderPool.feed` hands on that frame's positions exactly, so
#: the renderer gives its pixels again without drawing (a still cell: waits, settling, the
#: closing shot). 1e-5 rad turns a point 3 m away by 0.03 mm, under 1/100 px of a 640x480
#: overview, and the frames drawn never lag the states fed by more than this. Decided where the
#: frames are fed in order, so one process and W processes, a run and a replay of its
#: recording, hold the same frames. Measured on a ten-cycle run at 30 fps: 145 of 1612 frames.
HOLD = 1e-5
#: Most frames in a chunk (small: after Ctrl-C during a run, the frames handed out are still
#: written, at most workers x (AHEAD + 1/2) chunks).
MAX_CHUNK = 8
#: Seconds between checks for Ctrl-C while waiting for a frame [s].
POLL = 0.1
#: Bytes of frames a worker may hold ahead of the encoder (one chunk) [B].
WORKER_BUFFER = 32 * 2**20
#: Chunks handed to each worker ahead of the encoder (one rendering, one waiting).
AHEAD = 2
#: Seconds to wait for a killed worker to go.
JOIN_TIMEOUT = 10.0


def default_workers() -> int:
    """The number of cores this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def capped_workers(asked: int, frames: int | None = None) -> int:
    """Render processes worth starting for ``asked``: at most one per core, and at most one per
    frame to draw (``replay --workers 64`` started 64 processes for 39 frames: 60 s, not 2 s).
    """
    cap = default_workers() if frames is None else min(default_workers(), max(1, frames))
    return max(1, min(int(asked), cap))


def gl_threads_per_worker(workers: int) -> int:
    """Rasteriser threads for each of ``workers`` render processes (Mesa's ``LP_NUM_THREADS``).

    Mesa's software rasteriser (llvmpipe) starts a thread per core in every process. With a
    process per core or more, 0 (each process rasterises on its own thread, no hand-over) costs
    the least CPU a frame: over a run's frames at 640x480, 44 ms against 52 ms with one
    rasteriser thread and 55 ms with two. With fewer processes than cores, the cores are
    shared out between them.
    """
    cores = default_workers()
    return 0 if workers >= cores else cores // workers


def chunk_frames(settings: VideoSettings) -> int:
    """Frames per chunk for frames of this size: :data:`MAX_CHUNK`, fewer when that much would
    exceed :data:`WORKER_BUFFER`."""
    frame_bytes = settings.width * len(settings.cameras) * settings.height * 3
    return max(1, min(MAX_CHUNK, WORKER_BUFFER // frame_bytes))


class FrameRenderer:
    """Renders recorded states with the settings' cameras and quality (one GL context).

    Args:
        model: The cell model (its render-only fields are set from the settings; target shapes
            are set per frame).
        settings: Cameras, size and quality.
        target_geoms: Ids of the geoms whose shapes the frames carry.
    """

    def __init__(
        self, model: mujoco.MjModel, settings: VideoSettings, target_geoms: IntArray
    ) -> None:
        # fast and medium draw the video's level of detail (the close-ups of high the fine one)
        self.model = model if settings.quality == "high" else draw_level(model)
        model = self.model
        self.geoms = np.asarray(target_geoms, dtype=np.int32)
        self.cameras = [check_camera(model, c) for c in settings.cameras]
        bin_cam = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, "bin")
        #: The closing shot: the bin in the first view.
        self.tail_cameras = self.cameras if bin_cam < 0 else [bin_cam, *self.cameras[1:]]
        shadows, shadow_size, msaa = QUALITY[settings.quality]
        model.vis.quality.shadowsize = shadow_size
        model.vis.quality.offsamples = msaa
        self.shadows = shadows
        self.casters = shadow_casters(model)
        self.data = mujoco.MjData(model)
        self.renderer = make_renderer(model, settings.width, settings.height)
        #: The previous call's inputs and frame.
        self._last: tuple[FloatArray, FloatArray, bool, npt.NDArray[np.uint8]] | None = None
        #: Frames given again without drawing.
        self.reused = 0

    def render(self, qpos: FloatArray, shapes: FloatArray, tail: bool) -> npt.NDArray[np.uint8]:
        """One frame (height, width x cameras, 3) of the state ``qpos`` with target ``shapes``.

        The same inputs as the previous call's (a frame :meth:`RenderPool.feed` held, see
        :data:`HOLD`) give a copy of its pixels without drawing again: drawing is deterministic,
        so they are the pixels a draw would give.
        """
        last = self._last
        if (
            last is not None
            and last[2] == tail
            and np.array_equal(last[0], qpos)
            and np.array_equal(last[1], shapes)
        ):
            self.reused += 1
            return last[3].copy()
        frame = self._draw(qpos, shapes, tail)
        # A copy of our own: the caller may draw on the frame (the overlay is drawn in place).
        self._last = (np.array(qpos), np.array(shapes), tail, frame.copy())
        return frame

    def _draw(self, qpos: FloatArray, shapes: FloatArray, tail: bool) -> npt.NDArray[np.uint8]:
        apply_frame(self.model, self.data, qpos, self.geoms, shapes)
        views = []
        for cam in self.tail_cameras if tail else self.cameras:
            self.renderer.update_scene(self.data, camera=cam)
            self.renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = self.shadows
            if self.shadows:
                limit_shadows(self.renderer.scene, self.casters)
            views.append(self.renderer.render())
        return views[0] if len(views) == 1 else np.concatenate(views, axis=1)

    def close(self) -> None:
        """Free the GL context."""
        self.renderer.close()


def _worker(
    tasks: Connection,
    results: Connection,
    model_path: str,
    settings: dict[str, Any],
    geoms: IntArray,
    slots_name: str,
    free: Any,
    gl_threads: int,
) -> None:
    """A render worker: ``tasks`` brings ``(qpos, shapes, tail)`` chunks (None: stop); every
    frame is written into the next of the shared memory ``slots_name``'s slots (once ``free``,
    a semaphore counting the free slots, lets it) and announced on ``results`` as ``b"F"``; a
    failure as ``b"E" + message``."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent handles Ctrl-C
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    # Read when the GL context is made, below; a value set by the user stands.
    os.environ.setdefault("LP_NUM_THREADS", str(gl_threads))
    parent = os.getppid()
    try:
        shm = shared_memory.SharedMemory(name=slots_name)
        model = mujoco.MjModel.from_binary_path(model_path)
        video = VideoSettings(**settings)
        renderer = FrameRenderer(model, video, geoms)
    except Exception as exc:
        results.send_bytes(b"E" + " ".join(str(exc).split()).encode())
        return
    results.send_bytes(b"R")  # ready
    shape = (video.height, video.width * len(video.cameras), 3)
    slots = np.ndarray((shm.size // math.prod(shape), *shape), dtype=np.uint8, buffer=shm.buf)
    k = 0
    try:
        while True:
            try:
                task = tasks.recv()
            except EOFError:
                break
            if task is None:
                break
            qpos, shapes, tail = task
            for j in range(len(qpos)):
                frame = renderer.render(qpos[j], shapes[j], bool(tail[j]))
                while not free.acquire(timeout=POLL):
                    if os.getppid() != parent:  # the parent is gone
                        return
                slots[k % len(slots)] = frame
                results.send_bytes(b"F")
                k += 1
    except OSError:  # the parent is gone
        pass
    except Exception as exc:
        with contextlib.suppress(OSError):
            results.send_bytes(b"E" + " ".join(str(exc).split()).encode())
    finally:
        del slots
        shm.close()
        renderer.close()


class RenderPool:
    """Renders fed frames with ``workers`` processes and encodes them in order into an MP4.

    Args:
        model: The cell model the states belong to (saved as MJB for the workers).
        settings: What to render and where to write it.
        target_geoms: Ids of the geoms whose shapes each frame carries.
        workers: Render processes; 1 renders in this process.
        progress: Called with the number of frames written so far (often).

    Raises:
        RenderError: When the encoder, a worker or its GL context cannot be started.
        ConfigError: For a camera the model lacks or a frame too large.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        settings: VideoSettings,
        target_geoms: IntArray,
        workers: int = 1,
        progress: Callable[[int, float], None] | None = None,
    ) -> None:
        self.settings = settings
        self.workers = max(1, int(workers))
        self.progress = progress
        self.chunk = chunk_frames(settings)
        self.frame_shape = (settings.height, settings.width * len(settings.cameras), 3)
        self.fed = 0
        self.written = 0
        #: The failure that stopped this video during a run (set by the job), or None.
        self.error: Exception | None = None
        #: Per frame fed, not yet written: its status, positions and whether in the tail.
        self._lines: collections.deque[tuple[FrameStatus, FloatArray, bool]] = collections.deque()
        self._seen = SeenMarker(model, settings)  # marks what perception saw (--perceive)
        #: The positions last fed that were not held (see :data:`HOLD`).
        self._held: FloatArray | None = None
        self._pending: list[tuple[FloatArray, FloatArray, bool]] = []
        self._outstanding: collections.deque[tuple[int, int]] = collections.deque()
        self._next_chunk = 0
        self._procs: list[Any] = []
        self._tasks: list[Connection] = []
        self._results: list[Connection] = []
        #: Per worker: its frame slots in shared memory, their views, the semaphore counting
        #: the free ones, and the slot its next frame is in.
        self._shm: list[shared_memory.SharedMemory] = []
        self._slots: list[npt.NDArray[np.uint8]] = []
        self._free: list[Any] = []
        self._next_slot: list[int] = []
        self._tmpdir: tempfile.TemporaryDirectory[str] | None = None
        self._local: FrameRenderer | None = None
        geoms = np.asarray(target_geoms, dtype=np.int32)
        # The settings are checked against the model here, before a process is started.
        for c in settings.cameras:
            check_camera(model, c)
        check_frame_size(settings.width, settings.height)
        if self.workers == 1:
            self._local = FrameRenderer(model, settings, geoms)
        try:
            self.writer = _Writer(settings)
        except BaseException:
            if self._local is not None:
                self._local.close()
            raise
        if self.workers > 1:
            try:
                self._start(model, geoms)
            except BaseException:
                self.abort()
                raise

    # -- workers -------------------------------------------------------------------------
    def _start(self, model: mujoco.MjModel, geoms: IntArray) -> None:
        import multiprocessing as mp

        self._tmpdir = tempfile.TemporaryDirectory(prefix="kr210-render-")
        model_path = str(Path(self._tmpdir.name) / "model.mjb")
        mujoco.mj_saveModel(model, model_path, None)
        ctx = mp.get_context("spawn")
        gl_threads = gl_threads_per_worker(self.workers)
        settings = asdict(self.settings)
        settings["path"] = Path(settings["path"])
        # Started with SIGINT blocked: the workers inherit the mask, so Ctrl-C (sent to the whole
        # process group) never reaches them; a Ctrl-C meanwhile is delivered here afterwards.
        old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        try:
            for w in range(self.workers):
                task_r, task_w = ctx.Pipe(duplex=False)
                res_r, res_w = ctx.Pipe(duplex=False)
                size = self.chunk * math.prod(self.frame_shape)
                shm = shared_memory.SharedMemory(create=True, size=size)
                self._shm.append(shm)
                shape = (self.chunk, *self.frame_shape)
                self._slots.append(np.ndarray(shape, dtype=np.uint8, buffer=shm.buf))
                self._free.append(ctx.Semaphore(self.chunk))
                self._next_slot.append(0)
                args = (task_r, res_w, model_path, settings, geoms, shm.name, self._free[-1])
                proc = ctx.Process(
                    target=_worker,
                    args=(*args, gl_threads),
                    name=f"kr210-render-{w}",
                    daemon=True,
                )
                proc.start()
                task_r.close()
                res_w.close()
                self._procs.append(proc)
                self._tasks.append(task_w)
                self._results.append(res_r)
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, old)
        for w in range(self.workers):  # each has its model and GL context, or says why not
            try:
                first = self._results[w].recv_bytes()
            except (EOFError, OSError) as exc:
                raise self._died(w, exc) from exc
            if first[:1] == b"E":
                raise RenderError(first[1:].decode())

    def _dispatch(self) -> None:
        """Hand the pending frames to the next worker as one chunk (waiting for frames to be
        written while every worker is :data:`AHEAD` chunks ahead)."""
        while len(self._outstanding) >= self.workers * AHEAD:
            self._consume(block=True, limit=1)
        with deferred():  # a task is sent whole, and counted
            w = self._next_chunk % self.workers
            qpos = np.stack([p[0] for p in self._pending])
            shapes = np.stack([p[1] for p in self._pending])
            tail = np.array([p[2] for p in self._pending], dtype=bool)
            try:
                self._tasks[w].send((qpos, shapes, tail))
            except OSError as exc:
                raise self._died(w, exc) from exc
            self._outstanding.append((w, len(self._pending)))
            self._next_chunk += 1
            self._pending = []

    def _died(self, w: int, exc: BaseException) -> RenderError:
        proc = self._procs[w]
        proc.join(0.5)
        code = proc.exitcode
        return RenderError(
            f"render worker {w} stopped (exit code {code}, {type(exc).__name__}); "
            "try --render-workers 1"
        )

    def _receive(self, w: int) -> npt.NDArray[np.uint8]:
        try:
            msg = self._results[w].recv_bytes()
        except (EOFError, OSError) as exc:
            raise self._died(w, exc) from exc
        if msg[:1] == b"E":
            raise RenderError(f"render worker {w} failed: {msg[1:].decode()}")
        slot = self._next_slot[w]
        self._next_slot[w] = (slot + 1) % self.chunk
        frame = self._slots[w][slot].copy()
        self._free[w].release()
        return frame

    def _consume(self, block: bool, limit: int | None = None) -> None:
        """Write the next frames in order: those ready (or, with ``block``, waiting for them),
        at most ``limit`` chunks' worth of completions.

        An interrupt lands while waiting (nothing read yet) or after a frame is written and
        counted, never in between: :meth:`finish` can still write every frame fed after it.
        """
        done = 0
        while self._outstanding and (limit is None or done < limit):
            w, n = self._outstanding[0]
            conn = self._results[w]
            if not block and not conn.poll():
                return
            while not conn.poll(POLL):  # interruptible wait
                pass
            with deferred():
                self._write(self._receive(w))
                if n == 1:
                    self._outstanding.popleft()
                    done += 1
                else:
                    self._outstanding[0] = (w, n - 1)

    def _write(self, frame: npt.NDArray[np.uint8]) -> None:
        status, qpos, tail = self._lines.popleft()
        if status.seen_at is not None and not tail:
            self._seen.draw(frame, qpos, status)
        self.writer.put(frame, status.lines())
        self.written += 1
        if self.progress is not None:
            self.progress(self.written, status.time)

    # -- the public side -----------------------------------------------------------------
    def feed(self, qpos: FloatArray, shapes: FloatArray, status: FrameStatus, tail: bool) -> None:
        """Add the next frame: the state ``qpos``, target ``shapes``, the overlay's ``status``
        and whether it belongs to the closing shot."""
        held = self._held
        if held is not None and float(np.max(np.abs(qpos - held))) <= HOLD:
            qpos = held  # a still cell: drawn once (see HOLD)
        else:
            self._held = qpos = np.array(qpos, dtype=np.float64)
        with deferred():  # counted whole, or not at all
            self.fed += 1
            self._lines.append((status, qpos, tail))
            if self._local is not None:
                self._write(self._local.render(qpos, shapes, tail))
                return
            self._pending.append((qpos, shapes, tail))
        if len(self._pending) >= self.chunk:
            self._dispatch()
        self._consume(block=False)

    def finish(self) -> int:
        """Render and write every frame fed, stop the workers and move the MP4 into place.

        Returns:
            Frames written.

        Raises:
            RenderError: When rendering or encoding failed (the MP4 is not written).
            KeyboardInterrupt: Ctrl-C or SIGTERM: call :meth:`abort` to keep the frames so far.
        """
        if self._pending:
            self._dispatch()
        self._consume(block=True)
        self._stop_workers()
        self._close_local()
        self.writer.close()
        return self.written

    def abort(self, keep: bool = True) -> int:
        """Stop now: kill the workers and close the MP4 with the frames written so far (all
        consecutive from the first; no frame: no file), or with ``keep=False`` write no file
        (after a failure: an earlier file at the path stays as it was).

        Returns:
            Frames written (0 without ``keep``).

        Raises:
            RenderError: When the encoder failed.
        """
        self._kill_workers()
        self._close_local()
        if not hasattr(self, "writer"):
            return 0
        if not keep:
            self.writer.discard()
            return 0
        self.writer.close()
        return self.written

    def _close_local(self) -> None:
        if self._local is not None:
            self._local.close()
            self._local = None

    def _stop_workers(self) -> None:
        for conn in self._tasks:
            try:
                conn.send(None)
            except OSError:
                pass
        deadline = time.monotonic() + JOIN_TIMEOUT
        for proc in self._procs:
            proc.join(max(0.0, deadline - time.monotonic()))
        self._kill_workers()

    def _kill_workers(self) -> None:
        for proc in self._procs:
            if proc.is_alive():
                proc.kill()
        for proc in self._procs:
            proc.join(JOIN_TIMEOUT)
        for conn in (*self._tasks, *self._results):
            conn.close()
        self._procs, self._tasks, self._results = [], [], []
        self._slots, self._free, self._next_slot = [], [], []
        for shm in self._shm:
            shm.close()
            with contextlib.suppress(FileNotFoundError):
                shm.unlink()
        self._shm = []
        if self._tmpdir is not None:
            self._tmpdir.cleanup()
            self._tmpdir = None


def render_recording(
    recording: Recording,
    model: mujoco.MjModel,
    settings: VideoSettings,
    workers: int = 1,
    progress: Callable[[int, float], None] | None = None,
) -> tuple[int, KeyboardInterrupt | None]:
    """Render ``recording`` to ``settings.path`` (checked against ``model`` by the caller).

    Frame ``k`` of the video shows the last recorded state at or before ``k / fps`` [s] of
    simulated time; at the recording's own rate that is recorded frame ``k``. ``workers`` is
    capped at the cores and the frames (:func:`capped_workers`).

    Returns:
        Frames written, and the interrupt (Ctrl-C, SIGTERM) that stopped the render early, after
        which the MP4 holds the frames so far.

    Raises:
        RenderError: When rendering or encoding failed (no MP4 is written).
    """
    indices = frame_indices(recording, settings.fps)
    workers = capped_workers(workers, len(indices))
    pool = RenderPool(model, settings, recording.target_geoms, workers, progress)
    try:
        for i in indices:
            pool.feed(
                recording.arrays["qpos"][i],
                recording.shapes_at(i),
                recording.status(i),
                bool(recording.arrays["tail"][i]),
            )
        return pool.finish(), None
    except KeyboardInterrupt as exc:
        return pool.abort(keep=True), exc
    except BaseException:
        pool.abort(keep=False)
        raise


def frame_indices(recording: Recording, fps: int) -> list[int]:
    """Recorded frame of each video frame at ``fps``.

    Video frame ``k`` is due at ``k / fps`` [s]: it shows the first recorded frame due at or after
    that time (recorded frame ``j`` is due at ``j / rate``), the frame a live video at ``fps``
    would have taken when ``fps`` divides the rate (30 Hz: 30, 15, 10, 5, ...).
    """
    rate, n = recording.rate, recording.frames
    if abs(fps - rate) < 1e-9:
        return list(range(n))
    count = int(np.floor((n - 1) * fps / rate + 1e-9)) + 1
    return [min(n - 1, math.ceil(k * rate / fps - 1e-9)) for k in range(count)]
