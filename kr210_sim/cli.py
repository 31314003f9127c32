"""Command-line interface: ``python -m kr210_sim <command>``.

Commands: ``run`` (the main job), ``replay`` (render a recording of a run to MP4), ``view`` (the
same run live in MuJoCo Studio), ``evaluate``, ``ik-check``, ``check``, ``demos``,
``build-meshes``, ``build-scene``, ``snapshot``. Exit codes: 0 success, 1 a run below its pass
bar (or an IK failing a case), 2 a usage error or a failure with a one-line
message, 130 interrupted by Ctrl-C, 143 by SIGTERM, 129 by SIGHUP (the report of the cycles
completed so far is still written).
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from kr210_sim import __version__
from kr210_sim.errors import ConfigError, Kr210SimError
from kr210_sim.util.console import SafeStream
from kr210_sim.util.interrupts import exit_code, signal_name, terminate_as_interrupt
from kr210_sim.util.progress import ProgressLine

if TYPE_CHECKING:
    from kr210_sim.api import RunReport
    from kr210_sim.media.video import VideoSettings

DEFAULT_REPORT = Path("reports/run.json")
DEFAULT_EVAL_REPORT = Path("reports/evaluate.json")
DEFAULT_IK_REPORT = Path("reports/ik_check.json")
DEFAULT_VIEW_REPORT = Path("reports/view.json")
DEFAULT_DEMOS = Path("demos/pick_place.hdf5")
DEFAULT_RECORD_RATE = 30


class _Parser(argparse.ArgumentParser):
    """An argparse parser whose usage errors are one line and exit code 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        sys.stderr.write(f"{self.prog}: error: {message}\n")
        raise SystemExit(2)


def _parsed(text: str, cast: type[int] | type[float], expected: str) -> Any:
    try:
        return cast(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}") from None


def _check(ok: bool, message: str) -> None:
    if not ok:
        raise argparse.ArgumentTypeError(message)


def _positive_int(text: str) -> int:
    value: int = _parsed(text, int, "a whole number")
    _check(value >= 1, f"must be at least 1, got {value}")
    return value


def _cycles(text: str) -> int:
    from kr210_sim.sim.runner import MAX_CYCLES

    value = _positive_int(text)
    _check(value <= MAX_CYCLES, f"at most {MAX_CYCLES} in one run (use evaluate), got {value}")
    return value


def _slot(text: str) -> int:
    value: int = _parsed(text, int, "0-25")
    _check(
        0 <= value <= 25, f"must be 0 (random) or a slot 1-rows x columns (at most 25), got {value}"
    )
    return value


def _fraction(text: str) -> float:
    value: float = _parsed(text, float, "a number in [0, 1]")
    _check(0.0 <= value <= 1.0, f"must be in [0, 1], got {value}")
    return value


def _count(text: str) -> int:
    value: int = _parsed(text, int, "a whole number")
    _check(value >= 0, f"must be >= 0, got {value}")
    return value


def _seed(text: str) -> int:
    value: int = _parsed(text, int, "a whole number")
    _check(value >= 0, f"must be >= 0, got {value}")
    return value


def _multiple_of_16(text: str) -> int:
    value = _positive_int(text)
    _check(value % 16 == 0, f"must be a multiple of 16, got {value}")
    return value


def _fps(text: str) -> int:
    value = _positive_int(text)
    _check(value <= 120, f"must be 1-120, got {value}")
    return value


def _load_ik(spec: str | None) -> Any:
    """The user's IK for ``--ik SPEC`` (None without one); a bad SPEC is a one-line error here,
    before anything runs."""
    if spec is None:
        return None
    from kr210_sim.robot.user_ik import load_ik

    return load_ik(spec)


def _video_options(args: argparse.Namespace) -> dict[str, Any]:
    """The video options given on the command line (VideoSettings holds the defaults)."""
    return {
        k: v
        for k, v in (
            ("cameras", tuple(args.camera) if args.camera else None),
            ("width", args.width),
            ("height", args.height),
            ("fps", args.fps),
            ("quality", args.quality),
        )
        if v is not None
    }


def _cmd_run(args: argparse.Namespace) -> int:
    from kr210_sim.api import RunInterrupted, RunReport, run
    from kr210_sim.errors import VideoFailedError
    from kr210_sim.media.video import VideoSettings

    ik = _load_ik(args.ik)  # a bad SPEC is a one-line error here, before anything runs
    video = None
    given = _video_options(args)
    if args.video is not None:
        video = VideoSettings(path=args.video, **given)
    elif given:
        raise ConfigError("--camera, --width, --height, --fps and --quality need --video PATH")
    if args.render_workers is not None and video is None:
        raise ConfigError("--render-workers needs --video PATH")
    if args.record_rate is not None and args.record is None:
        raise ConfigError("--record-rate needs --record PATH")
    interrupted: RunInterrupted | None = None
    try:
        result = run(
            args.cycles,
            args.seed,
            args.slot,
            args.randomize,
            ik=ik,
            video=video,
            plots=args.plots,
            scene=args.scene,
            cell=args.cell,
            report=args.report,
            out=sys.stdout,
            record=args.record,
            record_rate=args.record_rate or DEFAULT_RECORD_RATE,
            render_workers=args.render_workers,
        )
    except RunInterrupted as exc:
        interrupted, result = exc, exc.report  # type: ignore[assignment]
    except VideoFailedError as exc:
        result = exc.report
    assert isinstance(result, RunReport)
    _print_run(result, video)
    if interrupted is not None:
        if result.video_error is not None:
            sys.stderr.write(f"kr210_sim: error: {result.video_error}\n")
        return exit_code(interrupted)
    if result.video_error is not None:
        sys.stderr.write(f"kr210_sim: error: {result.video_error} (the report was written)\n")
        return 2
    summary = result.summary
    passed = result.passed(args.min_success)
    sys.stdout.write(
        f"{'PASS' if passed else 'FAIL'}: {summary['successes']}/{summary['cycles']} "
        f"cycles succeeded (pass bar {args.min_success:.0%})\n"
    )
    return 0 if passed else 1


def _print_run(result: RunReport, video: VideoSettings | None) -> None:
    """The summary table and the outputs of ``run`` on stdout."""
    from kr210_sim.score.report import summary_table

    out = sys.stdout
    summary = dict(result.summary)
    out.write(summary_table(summary) + "\n")
    if "ik" in summary:
        s, t = summary["ik"], summary["ik"]["wall_time_s"]
        out.write(
            f"  IK {s['spec']}: {s['calls']} calls, {1e6 * t['per_call_mean']:.1f} us mean, "
            f"{1e6 * t['per_call_max']:.1f} us max per call\n"
        )
    out.write(f"  report: {result.path}\n")
    if result.record_path is not None and result.record_frames:
        size = result.record_path.stat().st_size / 1e6
        out.write(
            f"  recording: {result.record_path} ({result.record_frames} frames, {size:.2f} MB)\n"
        )
    if video is not None and result.video_error is None:
        frames = result.video_frames
        written = f"({frames} frames)" if frames else "not written (no frames)"
        out.write(f"  video: {video.path} {written}\n")
    if result.plot_paths:
        out.write(f"  plots: {', '.join(str(p) for p in result.plot_paths)}\n")


def _cmd_replay(args: argparse.Namespace) -> int:
    from kr210_sim.cell.load import model_at
    from kr210_sim.media.recording import check_model, read_recording
    from kr210_sim.media.render_pool import default_workers, render_recording
    from kr210_sim.media.video import VideoSettings
    from kr210_sim.util.outputs import check_distinct, check_writable, is_stream
    from kr210_sim.util.paths import SCENE_PATH

    rec = read_recording(args.recording)
    recorded_scene = rec.meta.get("scene")
    scene = (
        args.scene if args.scene is not None else Path(recorded_scene) if recorded_scene else None
    )
    model = model_at(scene)
    check_model(args.recording, rec, model)
    # Defaults: the run's own video settings when it had a video, else the video defaults.
    made: dict[str, Any] = dict(rec.meta.get("video") or {})
    if "cameras" in made:
        made["cameras"] = tuple(made["cameras"])
    given = _video_options(args)
    fps = given.get("fps", made.get("fps", round(rec.rate)))
    path = args.video if args.video is not None else args.recording.with_suffix(".mp4")
    video = VideoSettings(path=path, **{**made, **given, "fps": fps})
    check_writable(video.path)
    if is_stream(video.path):
        raise ConfigError(f"--video {video.path}: an MP4 needs a regular, seekable file")
    check_distinct(
        {"--video": video.path},
        {"the recording": args.recording, "--scene": scene if scene is not None else SCENE_PATH},
    )
    workers = args.workers if args.workers is not None else default_workers()
    line = ProgressLine(sys.stderr)
    total = rec.frames if fps == rec.rate else None

    def progress(frames: int, sim_time: float) -> None:
        if line.due():
            of = f"/{total}" if total else ""
            line.show(f"replay: {frames}{of} frames  sim {sim_time:5.1f} s  {line.elapsed:4.0f} s")

    frames, interrupted = render_recording(rec, model, video, workers, progress)
    line.end(f"replay: {frames} frames in {line.elapsed:.1f} s on {workers} worker(s)")
    written = f"({frames} frames)" if frames else "not written (no frames)"
    sys.stdout.write(f"  video: {video.path} {written}\n")
    if interrupted is not None:
        sys.stderr.write(
            f"kr210_sim: interrupted ({signal_name(interrupted)}); frames so far kept\n"
        )
        return exit_code(interrupted)
    return 0


def _speed(text: str) -> float:
    value: float = _parsed(text, float, "a number")
    _check(0.0 < value <= 1000.0, f"must be in (0, 1000], got {value}")
    return value


def _port(text: str) -> int:
    value: int = _parsed(text, int, "a port number")
    _check(0 <= value <= 65535, f"must be 0-65535, got {value}")
    return value


def _cmd_view(args: argparse.Namespace) -> int:
    from kr210_sim.score.report import summary_table
    from kr210_sim.sim.runner import RunConfig
    from kr210_sim.view.live import LiveSettings, run_joints, view_job
    from kr210_sim.view.studio import FREE_CAMERA, ViewerSettings, has_display

    mode = "window" if args.window else "web" if args.web or not has_display() else "window"
    settings = ViewerSettings(
        mode=mode,
        host=args.host,
        port=args.port,
        camera=args.camera or FREE_CAMERA,
        demo=args.demo,
        joints=args.joints,
        quality=args.quality,
    )
    if args.joints:
        if args.demo:
            raise ConfigError("--joints has no task to step through: drop --demo")
        run_joints(settings)
        return 0
    if args.replay is not None:
        return _view_replay(args, settings)
    config = RunConfig(cycles=args.cycles, seed=args.seed, slot=args.slot, randomize=args.randomize)
    live = LiveSettings(speed=args.speed, exit_when_done=args.exit_when_done)
    ik = _load_ik(args.ik)
    result = view_job(config, args.report, settings, live, scene=args.scene, ik=ik, cell=args.cell)
    out = sys.stdout
    summary = result.report["summary"]
    out.write(summary_table(summary) + "\n")
    out.write(
        f"  report: {result.report_path}\n  live pace: {result.real_time_factor:.2f}x real "
        f"time (asked {args.speed:g}x), {result.frames} viewer updates\n"
    )
    if result.interrupted:
        return result.exit_code or 130
    passed = summary["success_rate"] >= args.min_success
    out.write(
        f"{'PASS' if passed else 'FAIL'}: {summary['successes']}/{summary['cycles']} "
        f"cycles succeeded (pass bar {args.min_success:.0%})\n"
    )
    return 0 if passed else 1


def _view_replay(args: argparse.Namespace, settings: Any) -> int:
    """``view --replay REC``: play a recording in the viewer at ``--speed`` x real time."""
    from kr210_sim.cell.load import model_at
    from kr210_sim.media.recording import check_model, read_recording
    from kr210_sim.view.live import LiveSettings, replay_view

    if args.demo:
        raise ConfigError("--replay plays a recording: drop --demo")
    rec = read_recording(args.replay)
    recorded_scene = rec.meta.get("scene")
    scene = (
        args.scene if args.scene is not None else Path(recorded_scene) if recorded_scene else None
    )
    model = model_at(scene)
    check_model(args.replay, rec, model)
    live = LiveSettings(speed=args.speed, exit_when_done=args.exit_when_done)
    result = replay_view(rec, model, settings, live)
    sys.stdout.write(
        f"  replay: {result.frames}/{rec.frames} frames at {result.real_time_factor:.2f}x real "
        f"time (asked {args.speed:g}x)\n"
    )
    if result.interrupted is not None:
        if isinstance(result.interrupted, KeyboardInterrupt):
            return exit_code(result.interrupted)
        sys.stderr.write(f"kr210_sim: {result.interrupted}\n")
        return 130
    return 0


def _cmd_evaluate(args: argparse.Namespace) -> int:
    from kr210_sim.cell.load import model_for
    from kr210_sim.eval.evaluate import EvalConfig, evaluate
    from kr210_sim.util.outputs import check_writable

    config = EvalConfig(
        episodes=args.episodes,
        seed=args.seed,
        randomize=args.randomize,
        workers=args.workers,
        scene=args.scene,
        backend=args.backend,
        address=args.address,
        ik=args.ik,
        cell=args.cell,
    )
    _load_ik(args.ik)  # a bad SPEC is one line here, before any worker starts
    if config.backend == "ray":
        from importlib.util import find_spec

        from kr210_sim.eval.ray_backend import INSTALL_HINT

        if find_spec("ray") is None:
            raise ConfigError(INSTALL_HINT)
    check_writable(args.report)
    if args.record_failures is not None:
        from kr210_sim.util.outputs import check_folder

        check_folder(args.record_failures)
    model_for(args.scene, args.cell)  # a bad scene or cell fails here, before any worker starts
    outcome = evaluate(config, report=args.report, resume=args.resume)
    report = outcome.report
    s = report["summary"]
    lo, hi = s["success_rate_ci95"]
    out = sys.stdout
    out.write(
        f"  episodes      {s['episodes']}{' (interrupted)' if outcome.interrupted else ''}\n"
        f"  successes     {s['successes']} ({100 * s['success_rate']:.2f} %, "
        f"95 % CI {100 * lo:.2f}-{100 * hi:.2f} %)\n"
    )
    for reason, f in s["failures"].items():
        seeds = ", ".join(str(e["seed"]) for e in f["examples"])
        out.write(f"  {reason:<13} {f['count']}  (seeds {seeds})\n")
    ct = s["cycle_time"]
    ex = report["execution"]
    where = f"{ex['workers']} worker(s), {ex['backend']}"
    if ex["backend"] == "ray":
        where += f" ({ex['nodes']} node(s), {ex['cpus']} CPUs)"
    resumed = f", {ex['resumed_episodes']} resumed" if ex["resumed_episodes"] else ""
    out.write(
        f"  cycle time    mean {ct['mean']:.2f} s, p95 {ct['p95']:.2f} s, max {ct['max']:.2f} s\n"
        f"  wall time     {ex['wall_time_s']:.1f} s on {where}{resumed}\n"
        f"  report: {outcome.report_path}\n  episodes: {outcome.episodes_path}\n"
    )
    if args.record_failures is not None and outcome.signal is None:
        from kr210_sim.media.recording import record_failures

        made = record_failures(
            report["failed_episodes"],
            config.randomize,
            args.record_failures,
            config.cell or config.scene,
            ik=args.ik,
        )
        out.write(f"  failures recorded: {len(made)} in {args.record_failures}\n")
    if outcome.signal is not None:
        name = signal.Signals(outcome.signal).name
        sys.stderr.write(
            f"kr210_sim: interrupted ({name}) after {s['episodes']} episodes; "
            "continue with --resume\n"
        )
        return 128 + outcome.signal
    passed = s["success_rate"] >= args.min_success
    out.write(f"{'PASS' if passed else 'FAIL'}: pass bar {args.min_success:.1%}\n")
    return 0 if passed else 1


def _cmd_check(args: argparse.Namespace) -> int:
    from kr210_sim.cell.load import model_for
    from kr210_sim.plan.cellcheck import check_cell

    result = check_cell(model_for(args.scene, args.cell))
    sys.stdout.write(result.table() + "\n")
    return 0 if result.ok else 1


def _cmd_ik_check(args: argparse.Namespace) -> int:
    from kr210_sim.api import ik_check

    ik = _load_ik(args.ik)  # a bad SPEC is a one-line error here, before anything runs
    result = ik_check(ik, args.cases, args.seed, args.report, args.plots)
    out = sys.stdout
    out.write(result.text + "\n")
    out.write(f"  report: {args.report}\n")
    if result.plot_paths:
        out.write(f"  plots: {', '.join(str(p) for p in result.plot_paths)}\n")
    return 0 if result.passed else 1


def _cmd_demos(args: argparse.Namespace) -> int:
    from kr210_sim.envs.demos import record_demos

    s = record_demos(args.out, args.episodes, args.seed, args.control, args.randomize)
    sys.stdout.write(
        f"  episodes   {s.episodes} ({s.successes} succeeded)\n"
        f"  samples    {s.samples} policy steps\n  dataset: {s.path}\n"
    )
    return 0


def _cmd_build_scene(args: argparse.Namespace) -> int:
    from kr210_sim.cell.mjcf import build_scene

    for path in build_scene(args.out):
        print(f"wrote {path}")
    return 0


def _cmd_build_meshes(args: argparse.Namespace) -> int:
    from kr210_sim.robot.meshes import build_meshes

    paths = build_meshes(args.out) if args.out else build_meshes()
    print(f"wrote {len(paths)} meshes to {paths[0].parent if paths else args.out}")
    return 0


def _cmd_snapshot(args: argparse.Namespace) -> int:
    from kr210_sim.cell.load import model_for
    from kr210_sim.media.render import snapshot

    model = model_for(None, args.cell) if args.cell is not None else None
    path = snapshot(args.out, camera=args.camera, width=args.width, height=args.height, model=model)
    print(f"wrote {path}")
    return 0


def _add_cell_option(cmd: argparse.ArgumentParser) -> None:
    cmd.add_argument(
        "--cell",
        type=Path,
        default=None,
        metavar="PATH",
        help="cell file (TOML), e.g. scenes/cells/published.toml; compiled instead of --scene",
    )


def _add_run_options(cmd: argparse.ArgumentParser, report: Path = DEFAULT_REPORT) -> None:
    """The options ``run`` and ``view`` share."""
    cmd.add_argument("--cycles", type=_cycles, default=10, help="cycles to run (10)")
    cmd.add_argument("--seed", type=_seed, default=0, help="seed of the run's generator (0)")
    cmd.add_argument(
        "--slot",
        type=_slot,
        default=0,
        help="slot 1-9 (bottom row first), 0 = random per cycle (0)",
    )
    cmd.add_argument(
        "--randomize",
        action="store_true",
        help="randomise target pose, size, mass and friction per cycle",
    )
    cmd.add_argument("--report", type=Path, default=report, help=f"JSON report path ({report})")
    cmd.add_argument(
        "--min-success",
        type=_fraction,
        default=0.8,
        help="pass bar: exit 1 below this success rate (0.8)",
    )
    cmd.add_argument("--scene", type=Path, default=None, help="MJCF scene (scenes/kr210_cell.xml)")
    _add_cell_option(cmd)
    cmd.add_argument(
        "--ik",
        default=None,
        metavar="SPEC",
        help="plan with your IK: package.module:function or path/to/file.py:function",
    )


def _add_video_options(cmd: argparse.ArgumentParser, camera: str, fps: str) -> None:
    """The video options ``run`` and ``replay`` share (read back by :func:`_video_options`);
    ``camera`` and ``fps`` name their defaults in the help."""
    cmd.add_argument(
        "--camera",
        action="append",
        default=None,
        help=f"camera for the video ({camera}); repeat to tile views side by side",
    )
    cmd.add_argument("--width", type=_multiple_of_16, default=None, help="video width [px] (640)")
    cmd.add_argument("--height", type=_multiple_of_16, default=None, help="video height [px] (480)")
    cmd.add_argument("--fps", type=_fps, default=None, help=f"video frames per simulated s ({fps})")
    cmd.add_argument(
        "--quality",
        choices=("fast", "medium", "high"),
        default=None,
        help="fast: no shadows; medium: shadows (default); high: big shadow map, 4x MSAA",
    )


def build_parser() -> argparse.ArgumentParser:
    """The CLI's argument parser."""
    parser = _Parser(prog="kr210_sim", description="KUKA KR210 pick-and-place cell in MuJoCo.")
    parser.add_argument("--version", action="version", version=f"kr210_sim {__version__}")
    parser.add_argument("-v", "--verbose", action="store_true", help="log what the cell does")
    sub = parser.add_subparsers(dest="command", parser_class=_Parser, metavar="COMMAND")
    sub.required = True

    run = sub.add_parser("run", help="run and score pick-and-place cycles")
    _add_run_options(run)
    run.add_argument("--video", type=Path, default=None, help="write an MP4 of the run here")
    _add_video_options(run, "overview", "30")
    run.add_argument("--plots", type=Path, default=None, help="write PNG plots into this folder")
    run.add_argument(
        "--record", type=Path, default=None, help="write a recording of the run (.npz) here"
    )
    run.add_argument(
        "--record-rate",
        type=_fps,
        default=None,
        help=f"recorded states per simulated s ({DEFAULT_RECORD_RATE})",
    )
    run.add_argument(
        "--render-workers",
        type=_positive_int,
        default=None,
        help="processes rendering the video (one per core; 1: render in this process)",
    )
    run.set_defaults(func=_cmd_run)

    rp = sub.add_parser("replay", help="render a recording (run --record) to MP4")
    rp.add_argument("recording", type=Path, metavar="REC", help="the recording (.npz)")
    rp.add_argument("--video", type=Path, default=None, help="MP4 path (default: REC with .mp4)")
    _add_video_options(rp, "the run's, else overview", "the recording's rate")
    rp.add_argument(
        "--workers",
        type=_positive_int,
        default=None,
        help="render processes (one per core; 1: render in this process)",
    )
    rp.add_argument(
        "--scene",
        type=Path,
        default=None,
        help="MJCF scene the recording was made with (default: the one it names, else ours)",
    )
    rp.set_defaults(func=_cmd_replay)

    view = sub.add_parser("view", help="watch the cycles live in MuJoCo Studio (browser or window)")
    _add_run_options(view, report=DEFAULT_VIEW_REPORT)
    where = view.add_mutually_exclusive_group()
    where.add_argument(
        "--web",
        action="store_true",
        help="serve the viewer to a browser (the default without a display)",
    )
    where.add_argument(
        "--window", action="store_true", help="open a native window (needs a display)"
    )
    view.add_argument(
        "--port", type=_port, default=0, help="web viewer port (0: first free from 8080)"
    )
    view.add_argument(
        "--host",
        default="127.0.0.1",
        help="interface to listen on (127.0.0.1); 0.0.0.0 exposes the unauthenticated viewer",
    )
    view.add_argument(
        "--camera", default=None, help="start on a named camera (default: orbit from overview)"
    )
    view.add_argument(
        "--demo", action="store_true", help="pause before every phase until Next (key N)"
    )
    view.add_argument(
        "--joints", action="store_true", help="no task: pose the arm with six joint sliders"
    )
    view.add_argument(
        "--quality",
        choices=("full", "fast"),
        default="full",
        help="fast: no shadows, reflections, haze or post-processing (for software WebGL)",
    )
    view.add_argument(
        "--speed", type=_speed, default=1.0, help="simulated seconds per wall second (1)"
    )
    view.add_argument(
        "--replay",
        type=Path,
        default=None,
        metavar="REC",
        help="play a recording (run --record) instead of running the cycles",
    )
    view.add_argument(
        "--exit-when-done",
        action="store_true",
        help="exit when the cycles are done (default: keep showing until Ctrl-C)",
    )
    view.set_defaults(func=_cmd_view)

    ev = sub.add_parser("evaluate", help="Monte-Carlo evaluation over many seeded episodes")
    ev.add_argument("--episodes", type=_positive_int, default=100, help="episodes (100)")
    ev.add_argument(
        "--workers",
        type=_positive_int,
        default=None,
        help="local processes (1), or Ray tasks in flight (the cluster's CPUs)",
    )
    ev.add_argument(
        "--backend",
        choices=("local", "ray"),
        default="local",
        help="local: processes on this machine (default); ray: a Ray cluster",
    )
    ev.add_argument(
        "--address",
        default=None,
        help="Ray cluster to use: auto or HOST:PORT (default: start Ray on this machine)",
    )
    ev.add_argument(
        "--resume",
        action="store_true",
        help="continue from the episodes file beside --report, skipping episodes done",
    )
    ev.add_argument("--seed", type=_seed, default=0, help="seed of the episode seeds (0)")
    ev.add_argument("--randomize", action="store_true", help="randomise each episode's target")
    ev.add_argument("--scene", type=Path, default=None, help="MJCF scene (scenes/kr210_cell.xml)")
    _add_cell_option(ev)
    ev.add_argument(
        "--ik",
        default=None,
        metavar="SPEC",
        help="plan every episode with your IK: package.module:function or path/to/file.py:function",
    )
    ev.add_argument(
        "--report",
        type=Path,
        default=DEFAULT_EVAL_REPORT,
        help=f"JSON report path ({DEFAULT_EVAL_REPORT})",
    )
    ev.add_argument(
        "--min-success", type=_fraction, default=0.995, help="pass bar for exit 0 (0.995)"
    )
    ev.add_argument(
        "--record-failures",
        type=Path,
        default=None,
        metavar="DIR",
        help="record every failed episode as DIR/<seed>_<reason>.npz (replay renders it)",
    )
    ev.set_defaults(func=_cmd_evaluate)

    chk = sub.add_parser("check", help="can every slot and drop spot of a cell be served?")
    chk.add_argument("--scene", type=Path, default=None, help="MJCF scene (scenes/kr210_cell.xml)")
    _add_cell_option(chk)
    chk.set_defaults(func=_cmd_check)

    ikc = sub.add_parser("ik-check", help="grade an IK function on fixed and random poses")
    ikc.add_argument(
        "--ik",
        required=True,
        metavar="SPEC",
        help="package.module:function or path/to/file.py:function (ours: "
        "kr210_sim.robot.kinematics:nearest)",
    )
    ikc.add_argument(
        "--cases", type=_count, default=1000, help="random poses on top of the fixed set (1000)"
    )
    ikc.add_argument("--seed", type=_seed, default=0, help="seed of the random poses (0)")
    ikc.add_argument(
        "--report",
        type=Path,
        default=DEFAULT_IK_REPORT,
        help=f"JSON report path ({DEFAULT_IK_REPORT})",
    )
    ikc.add_argument("--plots", type=Path, default=None, help="write PNG plots into this folder")
    ikc.set_defaults(func=_cmd_ik_check)

    demos = sub.add_parser(
        "demos", help="record the scripted expert in the Gymnasium environment (HDF5 dataset)"
    )
    demos.add_argument("--episodes", type=_positive_int, default=10, help="episodes (10)")
    demos.add_argument(
        "--out", type=Path, default=DEFAULT_DEMOS, help=f"HDF5 file ({DEFAULT_DEMOS})"
    )
    demos.add_argument(
        "--control", choices=("joint", "cartesian"), default="joint", help="action space (joint)"
    )
    demos.add_argument("--seed", type=_seed, default=0, help="episode i is seeded seed + i (0)")
    demos.add_argument("--randomize", action="store_true", help="randomise the cylinders")
    demos.set_defaults(func=_cmd_demos)

    scene = sub.add_parser("build-scene", help="regenerate scenes/ from the URDF and the config")
    scene.add_argument("--out", type=Path, default=None, help="output folder (scenes/)")
    scene.set_defaults(func=_cmd_build_scene)

    meshes = sub.add_parser("build-meshes", help="regenerate the KR210 meshes")
    meshes.add_argument("--out", type=Path, default=None, help="output folder")
    meshes.set_defaults(func=_cmd_build_meshes)

    snap = sub.add_parser("snapshot", help="render a still of the cell offscreen")
    snap.add_argument("--camera", default="overview", help="camera name (overview)")
    snap.add_argument("--out", type=Path, default=Path("cell.png"), help="PNG path (cell.png)")
    snap.add_argument("--width", type=_positive_int, default=1280, help="width [px] (1280)")
    snap.add_argument("--height", type=_positive_int, default=720, help="height [px] (720)")
    _add_cell_option(snap)
    snap.set_defaults(func=_cmd_snapshot)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the CLI and return its exit code.

    While a command runs, stdout and stderr are :class:`~kr210_sim.util.console.SafeStream` objects
    (a
    closed pipe or a full device drops console output, never the run) and SIGTERM / SIGHUP
    stop it like Ctrl-C (:mod:`kr210_sim.util.interrupts`): exit 130, 143 or 129.
    """
    stdout, stderr = sys.stdout, sys.stderr
    sys.stdout, sys.stderr = SafeStream(stdout, "stdout"), SafeStream(stderr, "stderr")
    try:
        with terminate_as_interrupt():
            return _main(argv)
    finally:
        sys.stdout.flush()
        sys.stdout, sys.stderr = stdout, stderr


def _main(argv: list[str] | None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING,
        format="%(levelname)s %(name)s: %(message)s",
        stream=sys.stderr,
    )
    if getattr(args, "out", "") is None and args.command == "build-scene":
        from kr210_sim.util.paths import SCENES_DIR

        args.out = SCENES_DIR
    try:
        return int(args.func(args))
    except Kr210SimError as exc:
        table = getattr(exc, "table", None)
        if table:
            sys.stderr.write(table + "\n")
        sys.stderr.write(f"kr210_sim: error: {exc}\n")
        return 2
    except KeyboardInterrupt as exc:
        sys.stderr.write(f"kr210_sim: interrupted ({signal_name(exc)})\n")
        return exit_code(exc)
