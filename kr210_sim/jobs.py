"""The jobs behind the commands, as functions the CLI and tests call.

The main one, :func:`run_job`, is what ``python -m kr210_sim run`` does; :func:`view_job` is
``view``, the same cycles through the same loop (:func:`kr210_sim.sim.session.run_session`),
paced to real time in the viewer.

Order of work of a run: check every output path first (a usage error costs nothing: unwritable
paths and outputs that clash with each other or with an input are refused before anything
runs), run the cycles (with the state recorders as step hooks: one keeps the states for
``--record``, one feeds the video's render pool, so rendering overlaps the simulation), append
the closing bin shot, then write the report, the recording, finish the video and write the
plots. The report is written even when the video fails or the run is interrupted (Ctrl-C,
SIGTERM): the failure is reported afterwards, and an interrupted video keeps the frames of the
states simulated so far.

The others: :func:`evaluate_job` (``evaluate``'s checks before any worker starts),
:func:`check_job` (``check``) and :func:`snapshot_job` (``snapshot``); ``replay``'s job is
:func:`kr210_sim.media.replay.replay_job`.
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

from kr210_sim.cell.load import model_for
from kr210_sim.errors import ConfigError, RenderError, UnservableCellError, one_line
from kr210_sim.media.plots import PLOT_NAMES
from kr210_sim.media.recording import (
    DEFAULT_RATE,
    DEFAULT_TAIL,
    StateRecorder,
    check_recording_path,
    model_identity,
    run_meta,
    write_recording,
)
from kr210_sim.media.render_pool import RenderPool, capped_workers, default_workers
from kr210_sim.media.video import VideoSettings
from kr210_sim.sandbox.user_ik import UserIk
from kr210_sim.score.result import CycleResult
from kr210_sim.sim.perceived import with_seen
from kr210_sim.sim.runner import RunConfig, Runner
from kr210_sim.sim.session import run_session, runner_report, unstarted_report
from kr210_sim.util.interrupts import cuttable, end_start_up, exit_code, signal_name, winding_up
from kr210_sim.util.outputs import (
    check_distinct,
    check_folder,
    check_writable,
    is_stream,
    write_json_atomic,
)
from kr210_sim.util.paths import SCENE_PATH, URDF_PATH
from kr210_sim.util.progress import VideoProgress

import mujoco  # isort: skip

if TYPE_CHECKING:
    from kr210_sim.eval.evaluate import EvalConfig, EvalOutcome
    from kr210_sim.plan.cellcheck import CellCheck
    from kr210_sim.sandbox.perception_sandbox import PerceptionSandbox
    from kr210_sim.view.live import LiveSettings
    from kr210_sim.view.studio import LiveViewer, ViewerSettings


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
        record_frames: Frames in the recording (0 without one).
    """

    report: dict[str, Any]
    report_path: Path | None
    interrupted: KeyboardInterrupt | None = None
    video_frames: int = 0
    video_error: str | None = None
    plot_paths: list[Path] = field(default_factory=list)
    sim_time: float = 0.0
    results: list[CycleResult] = field(default_factory=list)
    record_frames: int = 0


def check_outputs(
    report_path: Path | None,
    video: VideoSettings | None,
    plots_dir: Path | None,
    scene: Path | None,
    ik: UserIk | None = None,
    cell: Path | None = None,
    record: Path | None = None,
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
    if record is not None:
        check_recording_path(record)
        outputs["--record"] = record
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
    """Refuse a cell (another than the committed one) none of whose slots can be served, or
    none of whose drop spots a dropped cylinder reaches the bin's floor from.

    The drop spots are tested first (rays, no planning: such a cell is refused in one line);
    then the slots are planned in turn until one can be served (usually the first: a cycle's
    planning); only a cell that serves none is checked whole, for the table.

    Raises:
        UnservableCellError: With the check's table (see :mod:`kr210_sim.plan.cellcheck`), or
            none when no drop spot reaches the floor.
    """
    from kr210_sim.cell.layout import CellLayout
    from kr210_sim.plan.cellcheck import check_cell, first_served_slot
    from kr210_sim.plan.landing import landing_blockers

    layout = CellLayout.from_model(model)
    landing = landing_blockers(model, layout)
    if all(landing):
        others = f"; at the {len(landing) - 1} other drop spots too" if len(landing) > 1 else ""
        raise UnservableCellError(
            f"cell {layout.name}: no drop spot can be served, so no cycle can succeed: "
            f"{landing[0].replace('dropped here', 'dropped at drop 1')}{others} (clear the "
            "space above the bin)",
            "",
        )
    if first_served_slot(model):
        return
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
    record: Path | None = None,
    record_rate: float = DEFAULT_RATE,
    render_workers: int | None = None,
    perception: PerceptionSandbox | None = None,
) -> JobResult:
    """Run ``config.cycles`` cycles and write the report (and recording, video and plots).

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
        record: Where to write a recording of the run (``.npz``), or None.
        record_rate: Frames per simulated second of the recording [Hz].
        render_workers: Processes that render the video (default: one per core; 1 renders in
            this process).
        perception: With ``config.perceive``, a user's perception function (started) in place
            of our pipeline (``--perception SPEC``).

    Returns:
        The job's result; ``video_error`` is set (and the report still written) when the video
        could not be made; ``interrupted`` when Ctrl-C or SIGTERM stopped the cycles (the report
        then holds those finished, the recording their states, and the video the frames of the
        states simulated so far).

    Raises:
        ConfigError: When an output path cannot be written or clashes with another path (checked
            before any cycle runs).
        SceneError: When the scene cannot be loaded.
    """
    out = out or sys.stdout
    check_outputs(report_path, video, plots_dir, scene, ik, cell, record)
    pool: RenderPool | None = None
    try:  # an interrupt before the first cycle: a report of none, marked interrupted
        end_start_up()  # the command's: a signal held since its start-up is raised here
        # Without --scene or --cell the runner loads the committed scene itself, after the URDF
        # (a recording or a video needs the model's identity first: then it is loaded here).
        model = identity = None
        if scene is not None or cell is not None or record is not None or video is not None:
            model = model_for(scene, cell)
            identity = model_identity(model)  # of the model as loaded, before the run changes it
        if scene is not None or cell is not None:
            assert model is not None
            refuse_unservable(model)
        perceiver = None
        since = (0, 0) if perception is None else perception.mark()
        if config.perceive:  # renders the cell's sensors: imported only for --perceive
            from kr210_sim.sensors.perceiver import Perceiver

            perceiver = Perceiver
            if perception is not None:
                from kr210_sim.sensors.user_perceiver import user_perceiver

                perceiver = user_perceiver(perception)  # type: ignore[assignment]
        keep = plots_dir is not None
        runner = Runner(config, model=model, keep_recordings=keep, ik=ik, perceiver=perceiver)
        geoms = runner.cell.handles.target_geoms
        recorders: list[StateRecorder] = []
        states: StateRecorder | None = None
        if record is not None:
            states = StateRecorder(runner.model, geoms, runner.status, rate=record_rate)
            recorders.append(states)
        progress: VideoProgress | None = None
        video_error: str | None = None
        if video is not None:
            progress = VideoProgress(config.cycles, progress_stream, tail=video.tail)
            workers = (
                capped_workers(render_workers) if render_workers is not None else default_workers()
            )
            try:  # a bad camera or size raises ConfigError here, before anything has run
                pool = RenderPool(runner.model, video, geoms, workers, progress)
            except RenderError as exc:  # no GL backend or no encoder: run, report, then fail
                video_error = str(exc)
            else:
                sink, seen = _guarded(pool), with_seen(runner.status, runner.perceiver)
                recorders.append(StateRecorder(runner.model, geoms, seen, video.fps, False, sink))
    except KeyboardInterrupt as exc:
        with winding_up(exc):
            if pool is not None:
                pool.abort(keep=False)
            report = unstarted_report(config, exc)
            if report_path is not None:
                write_json_atomic(report_path, report)
        return JobResult(report, report_path, exc)

    def closing_shot() -> None:  # the bin with the cylinders in it
        if recorders:
            for r in recorders:
                r.tail = True
            runner.idle(video.tail if video is not None else DEFAULT_TAIL)

    end = run_session(
        runner,
        out,
        hooks=recorders,
        after=None if progress is None else lambda i: progress.cycle_done(i, runner.cell.time),
        closing=closing_shot,
    )
    interrupted = end.interrupted if isinstance(end.interrupted, KeyboardInterrupt) else None
    # Whatever signals follow (a CI cancel sends two), the outputs of the cycles done are
    # written whole; only the video's last frames may be cut short by a further one.
    with winding_up(interrupted):
        if interrupted is not None:  # Ctrl-C, or SIGTERM / SIGHUP (kr210_sim.util.interrupts)
            sys.stderr.write(
                f"kr210_sim: interrupted after {len(runner.results)} cycles "
                f"({signal_name(interrupted)}); writing the report of those\n"
            )
        report = runner_report(runner, end.wall_time, interrupted)
        if perception is not None and "perception" in report["summary"]:
            report["summary"]["perception"]["function"] = perception.summary(since)
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
        if states is not None and record is not None and identity is not None:
            result.record_frames = states.frames
            write_recording(
                record,
                states.recording(
                    _recording_meta(
                        config, identity, video, scene if scene is not None else cell, report
                    )
                ),
            )
        if pool is not None:
            result.video_frames, result.video_error, stopped = _finish_video(pool)
            result.interrupted = result.interrupted or stopped
            if progress is not None:
                progress.finish(result.video_frames)
        if plots_dir is not None and runner.results:
            from kr210_sim.media.plots import write_plots

            result.plot_paths = write_plots(
                plots_dir, runner.results, runner.recordings, runner.robot
            )
    return result


def _recording_meta(
    config: RunConfig,
    identity: str,
    video: VideoSettings | None,
    source: Path | None,
    report: dict[str, Any],
) -> dict[str, Any]:
    """The recording's metadata: the run, its model and report, the video's settings."""
    settings = None
    if video is not None:
        settings = {
            "cameras": list(video.cameras),
            "width": video.width,
            "height": video.height,
            "fps": video.fps,
            "quality": video.quality,
        }
    return run_meta(config, identity, source, report, settings)


def _guarded(pool: RenderPool) -> Any:
    """The video recorder's sink: frames go to ``pool`` until it fails; then the video is
    dropped (its error kept on the pool) and the simulation goes on unchanged. An interrupt is
    not an error and goes through."""

    def sink(*frame: Any) -> None:
        if pool.error is not None:
            return
        try:
            pool.feed(*frame)
        except Exception as exc:
            pool.error = exc
            with contextlib.suppress(RenderError):  # the encoder's own failure, said once
                pool.abort(keep=False)

    return sink


def _finish_video(pool: RenderPool) -> tuple[int, str | None, KeyboardInterrupt | None]:
    """Render what is left and close the MP4: (frames, error, interrupt). Ctrl-C here keeps the
    frames so far."""
    if pool.error is not None:
        return (
            0,
            f"video recording failed: {one_line(pool.error)}",
            None,
        )
    try:
        with cuttable():  # a further signal stops the rendering of the last frames
            return pool.finish(), None, None
    except KeyboardInterrupt as exc:
        try:
            return pool.abort(keep=True), None, exc
        except RenderError as err:
            return 0, str(err), exc
    except RenderError as exc:
        with contextlib.suppress(RenderError):  # the encoder's own failure, said once
            pool.abort(keep=False)
        return 0, str(exc), None


def evaluate_job(
    config: EvalConfig, report: Path, resume: bool = False, record_failures: Path | None = None
) -> EvalOutcome:
    """The ``evaluate`` command: check everything that can be checked before a worker starts
    (the IK SPEC, Ray installed for ``backend="ray"``, the report path, the folder for the failed
    episodes' recordings, the scene or cell), then evaluate.

    Raises:
        ConfigError, IkSpecError, SceneError: On a bad input, before any episode runs.
    """
    from kr210_sim.eval.evaluate import evaluate

    if config.ik is not None:  # with --ik-timeout, in a process of its own
        from kr210_sim.sandbox.guarded import load_user_ik

        load_user_ik(config.ik, config.ik_timeout)
    if config.backend == "ray":
        from importlib.util import find_spec

        from kr210_sim.eval.ray_backend import INSTALL_HINT

        if find_spec("ray") is None:
            raise ConfigError(INSTALL_HINT)
    check_writable(report)
    if record_failures is not None:
        check_folder(record_failures)
    model_for(config.scene, config.cell)
    return evaluate(config, report=report, resume=resume)


def check_job(scene: Path | None = None, cell: Path | None = None) -> CellCheck:
    """The ``check`` command: can every slot and drop spot of the cell be served?"""
    from kr210_sim.plan.cellcheck import check_cell

    return check_cell(model_for(scene, cell))


def snapshot_job(
    out: Path,
    camera: str = "overview",
    width: int = 1280,
    height: int = 720,
    cell: Path | None = None,
) -> Path:
    """The ``snapshot`` command: a still of the committed scene, or of ``cell``, as a PNG.

    Raises:
        ConfigError: ``out`` does not end in ``.png``, cannot be written, or names an input.
    """
    from kr210_sim.media.render import snapshot

    check_writable(out)
    check_distinct({"--out": out}, {"--cell": cell, "the scene": SCENE_PATH})
    if out.suffix.lower() != ".png" and not is_stream(out):
        raise ConfigError(f"--out {out}: snapshot writes a PNG; give a path ending in .png")
    model = model_for(None, cell) if cell is not None else None
    return snapshot(out, camera=camera, width=width, height=height, model=model)


@dataclass
class ViewResult:
    """What a live run produced.

    Attributes:
        report: The JSON-ready report (as ``run`` writes it).
        report_path: Where it was written.
        interrupted: True when Ctrl-C, SIGTERM (or closing the viewer) stopped the run early.
        exit_code: The exit code the interrupt asks for (130 Ctrl-C, 143 SIGTERM), else 0.
        real_time_factor: Simulated over wall time while running (demo pauses excluded).
        frames: Viewer updates sent.
        paused: Phases demo mode paused before, in order.
    """

    report: dict[str, Any]
    report_path: Path
    interrupted: bool
    real_time_factor: float
    frames: int
    paused: list[str]
    exit_code: int = 0


def view_job(
    config: RunConfig,
    report_path: Path,
    settings: ViewerSettings,
    live: LiveSettings,
    out: TextIO | None = None,
    scene: Path | None = None,
    on_ready: Callable[[LiveViewer], None] | None = None,
    ik: UserIk | None = None,
    cell: Path | None = None,
) -> ViewResult:
    """Run ``config.cycles`` cycles live in the viewer and write the report.

    The cycles run as ``run`` runs them (:func:`run_session`), with two hooks that never touch
    the physics: the pacer (:class:`kr210_sim.view.live.Pacer`) and, in demo mode, the demo
    gate before every phase of the cycle plan (:class:`kr210_sim.view.live.DemoGate`).

    Args:
        config: The run's settings (as for ``run``).
        report_path: JSON report path.
        settings: Viewer settings.
        live: Pace and exit behaviour.
        out: Where the URL, the per-cycle lines and the demo prompts go (stdout).
        scene: MJCF scene path (default: the committed scene).
        on_ready: Called with the open viewer before the first cycle (tests press Next with it).
        ik: A user's IK function to plan with (as ``run --ik``).
        cell: Cell file (TOML), compiled instead of a scene.

    Returns:
        The report and the measured pace.

    Raises:
        ConfigError: An unwritable report path, a busy port, no display for ``--window``.
        UnservableCellError: A cell none of whose slots can be served (as ``run``).
    """
    from kr210_sim.view.live import DemoGate, Pacer, ViewerSession, announce, hold_open
    from kr210_sim.view.studio import LiveViewer, ViewerClosed

    out = out or sys.stdout
    check_outputs(report_path, None, None, scene, ik, cell)
    viewer: LiveViewer | None = None
    try:
        try:  # an interrupt before the first cycle: a report of none, marked interrupted
            end_start_up()  # the command's: a signal held since its start-up is raised here
            model = None
            if scene is not None or cell is not None:
                model = model_for(scene, cell)
                refuse_unservable(model)
            runner = Runner(config, model=model, ik=ik)
            viewer = LiveViewer(runner.model, settings)
            session = ViewerSession(viewer, runner, out)
            announce(viewer, settings, out)
            if on_ready is not None:
                on_ready(viewer)
            pacer = Pacer(session.publish, live.speed, live.fps)
            session.pacer = pacer
            gate = DemoGate(session.wait_next) if settings.demo else None
        except KeyboardInterrupt as exc:
            with winding_up(exc):
                report = unstarted_report(config, exc)
                write_json_atomic(report_path, report)
            return ViewResult(report, report_path, True, 0.0, 0, [], exit_code(exc))
        end = run_session(
            runner, out, hooks=[pacer], on_phase=gate, stops=(KeyboardInterrupt, ViewerClosed)
        )
        interrupted = end.interrupted
        signalled = interrupted if isinstance(interrupted, KeyboardInterrupt) else None
        with winding_up(signalled) as held:  # written whole, whatever signals follow
            pacer.finish()
            if interrupted is not None:
                why = f"interrupted ({signal_name(signalled)})" if signalled else str(interrupted)
                sys.stderr.write(f"kr210_sim: {why} after {len(runner.results)} cycles\n")
            report = runner_report(runner, end.wall_time, signalled or interrupted is not None)
            write_json_atomic(report_path, report)
        result = ViewResult(
            report,
            report_path,
            interrupted is not None,
            pacer.real_time_factor,
            pacer.frames,
            gate.paused if gate is not None else [],
            exit_code(interrupted) if interrupted is not None else 0,
        )
        if not interrupted and not held and not live.exit_when_done:
            runner.status["phase"] = "done"
            out.write(f"done; report: {report_path}; the viewer stays open: Ctrl-C to quit\n")
            out.flush()
            hold_open(lambda: session.publish(runner.cell))
        return result
    finally:
        if viewer is not None:
            viewer.close()
