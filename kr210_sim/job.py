"""The main job: run N cycles, print them, write the report, optionally film and plot the run.

This is what ``python -m kr210_sim run`` does, as a function the CLI and tests call. Order of
work: check every output path first (a usage error costs nothing: unwritable paths and outputs
that clash with each other or with an input are refused before anything runs), run the cycles
(with the video recorder as a step hook), append the closing bin shot, then write the report,
finish the video and write the plots. The report is written even when the video fails or the
run is interrupted (Ctrl-C, SIGTERM): the failure is reported afterwards, and an interrupted
video keeps the frames recorded so far.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

from kr210_sim.cells import model_for
from kr210_sim.errors import ConfigError, RenderError, UnservableCellError
from kr210_sim.ik_plugin import UserIk
from kr210_sim.interrupts import signal_name
from kr210_sim.outputs import check_distinct, check_folder, check_writable, is_stream
from kr210_sim.paths import SCENE_PATH, URDF_PATH
from kr210_sim.plots import PLOT_NAMES
from kr210_sim.report import build_report, cycle_line, write_json_atomic
from kr210_sim.runner import CycleResult, RunConfig, Runner
from kr210_sim.video import FrameRecorder, Progress, VideoSettings, overlay_lines

import mujoco  # isort: skip


@dataclass
class JobResult:
    """What a job produced.

    Attributes:
        report: The JSON-ready report.
        report_path: Where it was written (None: not written).
        interrupted: The interrupt that stopped the run early (Ctrl-C, SIGTERM), or None.
        video_frames: Frames written to the video (0 without one).
        video_error: The one-line reason the video failed, or None.
        plot_paths: PNG plots written.
        sim_time: Simulated time at the end of the job, closing shot included [s].
        results: The cycles run, as the runner scored them.
    """

    report: dict[str, Any]
    report_path: Path | None
    interrupted: KeyboardInterrupt | None = None
    video_frames: int = 0
    video_error: str | None = None
    plot_paths: list[Path] = field(default_factory=list)
    sim_time: float = 0.0
    results: list[CycleResult] = field(default_factory=list)


def check_outputs(
    report_path: Path | None,
    video: VideoSettings | None,
    plots_dir: Path | None,
    scene: Path | None,
    ik: UserIk | None = None,
    cell: Path | None = None,
) -> None:
    """Refuse, before anything runs, outputs that cannot be written or that clash.

    Raises:
        ConfigError: An output path is unwritable, two outputs name one file, or an output names
            an input (the scene or cell file, the URDF, the IK file).
    """
    if report_path is not None:
        check_writable(report_path)
    outputs: dict[str, Path | None] = {"--report": report_path}
    if video is not None:
        check_writable(video.path)
        if is_stream(video.path):
            raise ConfigError(f"--video {video.path}: an MP4 needs a regular, seekable file")
        outputs["--video"] = video.path
    if plots_dir is not None:
        check_folder(plots_dir, PLOT_NAMES)
        outputs.update({f"--plots {name}": plots_dir / name for name in PLOT_NAMES})
    inputs: dict[str, Path | None] = {
        "--scene": scene if scene is not None else SCENE_PATH,
        "--cell": cell,
        "the URDF": URDF_PATH,
        "--ik": ik.source if ik is not None else None,
    }
    check_distinct(outputs, inputs)


def refuse_unservable(model: mujoco.MjModel) -> None:
    """Refuse a cell (another than the committed one) none of whose slots can be served.

    Raises:
        UnservableCellError: With the check's table (see :mod:`kr210_sim.cellcheck`).
    """
    from kr210_sim.cellcheck import check_cell

    result = check_cell(model)
    if not result.any_slot:
        raise UnservableCellError(
            f"cell {result.name}: no slot can be served (see the table above)", result.table()
        )


def run_job(
    config: RunConfig,
    report_path: Path | None,
    video: VideoSettings | None = None,
    plots_dir: Path | None = None,
    out: TextIO | None = None,
    progress_stream: TextIO | None = None,
    scene: Path | None = None,
    ik: UserIk | None = None,
    cell: Path | None = None,
) -> JobResult:
    """Run ``config.cycles`` cycles and write the report (and video, and plots).

    Args:
        config: The run's settings.
        report_path: JSON report path (None: the report is returned, not written).
        video: Video settings, or None for no video.
        plots_dir: Folder for the PNG plots, or None.
        out: Where the per-cycle lines go (stdout).
        progress_stream: Where the video progress bar goes (stderr).
        scene: MJCF scene path (default: the committed scene).
        cell: Cell file (TOML), compiled instead of a scene.
        ik: A user's IK function to plan with (default: our closed form); the report's summary
            then has an ``ik`` block (SPEC, calls, wall time per call).

    Returns:
        The job's result; ``video_error`` is set (and the report still written) when the video
        could not be made; ``interrupted`` when Ctrl-C or SIGTERM stopped the cycles (the report
        then holds those finished, and the video the frames so far).

    Raises:
        ConfigError: When an output path cannot be written or clashes with another path (checked
            before any cycle runs).
        SceneError: When the scene cannot be loaded.
    """
    out = out or sys.stdout
    check_outputs(report_path, video, plots_dir, scene, ik, cell)
    # Without --scene or --cell the runner loads the committed scene itself, after the URDF.
    model = model_for(scene, cell) if scene is not None or cell is not None else None
    if model is not None:
        refuse_unservable(model)
    runner = Runner(
        config,
        model=model,
        keep_recordings=plots_dir is not None,
        ik=ik,
    )
    recorder: FrameRecorder | None = None
    progress: Progress | None = None
    video_error: str | None = None
    if video is not None:
        progress = Progress(config.cycles, progress_stream, tail=video.tail)
        status = runner.status
        sim = runner.cell

        def lines() -> list[str]:
            return overlay_lines(status, sim.time)

        try:  # a bad camera or size raises ConfigError here, before anything has run
            recorder = FrameRecorder(runner.model, video, lines, progress)
        except RenderError as exc:  # no GL backend or no encoder: run, report, then fail
            video_error = str(exc)
        else:
            runner.cell.hooks.append(recorder)

    wall0 = time.perf_counter()
    interrupted: KeyboardInterrupt | None = None
    try:
        for i in range(1, config.cycles + 1):
            cycle = runner.run_cycle(i, runner.slot_for_cycle())
            out.write(cycle_line(cycle, config.cycles) + "\n")
            out.flush()
            if progress is not None:
                progress.cycle_done(i, runner.cell.time)
        if recorder is not None and recorder.error is None:
            recorder.override = recorder.tail_cameras()
            runner.idle(recorder.settings.tail)
    except KeyboardInterrupt as exc:  # Ctrl-C, or SIGTERM / SIGHUP (kr210_sim.interrupts)
        interrupted = exc
        sys.stderr.write(
            f"kr210_sim: interrupted after {len(runner.results)} cycles ({signal_name(exc)}); "
            "writing the report of those\n"
        )
    wall = time.perf_counter() - wall0
    report = build_report(
        config,
        runner.results,
        wall,
        interrupted=interrupted,
        events=runner.events,
        cell=runner.layout.describe(),
    )
    if runner.planner.user_ik is not None:
        report["summary"]["ik"] = runner.planner.user_ik.summary()
    if report_path is not None:
        write_json_atomic(report_path, report)
    result = JobResult(
        report,
        report_path,
        interrupted,
        video_error=video_error,
        sim_time=runner.cell.time,
        results=list(runner.results),
    )

    if recorder is not None:
        runner.cell.hooks.remove(recorder)
        try:
            result.video_frames = recorder.close()
        except RenderError as exc:
            result.video_error = str(exc)
        if progress is not None:
            progress.finish(result.video_frames)
    if plots_dir is not None and runner.results:
        from kr210_sim.plots import write_plots

        result.plot_paths = write_plots(plots_dir, runner.results, runner.recordings, runner.robot)
    return result
