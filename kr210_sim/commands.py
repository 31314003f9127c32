"""The commands of ``python -m kr210_sim``: each calls its job and prints what it made.

One function per command, called by :mod:`kr210_sim.cli` (which parses the arguments and maps
library errors to one-line messages and exit codes) with the parsed arguments; each returns the
command's exit code. The work itself is in :mod:`kr210_sim.jobs`, :mod:`kr210_sim.api` and the
subpackages.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
from typing import TYPE_CHECKING, Any, TextIO, cast

from kr210_sim.errors import ConfigError
from kr210_sim.util.console import EscapingStream
from kr210_sim.util.interrupts import end_start_up, exit_code, signal_name
from kr210_sim.util.progress import ProgressLine

if TYPE_CHECKING:
    from kr210_sim.api import RunReport
    from kr210_sim.media.video import VideoSettings

#: Recorded states per simulated second without ``--record-rate`` [Hz].
DEFAULT_RECORD_RATE = 30


def _no_jail(args: argparse.Namespace) -> None:
    """``--no-jail`` for ``--ik-timeout``: say what is then not protected, and have every
    process of this command (evaluate's workers too) start the IK unjailed.

    Raises:
        ConfigError: ``--no-jail`` without ``--ik-timeout`` (there is no process to jail).
    """
    if not getattr(args, "no_jail", False):
        return
    if args.ik_timeout is None and getattr(args, "perception", None) is None:
        raise ConfigError(
            "--no-jail needs --ik-timeout S: without it your IK runs in this process, unjailed"
        )
    from kr210_sim.sandbox.jail import JAIL_ENV, unjailed_warning

    os.environ[JAIL_ENV] = "0"
    if args.ik_timeout is not None:
        sys.stderr.write(unjailed_warning("your IK's"))
    if getattr(args, "perception", None) is not None:
        sys.stderr.write(unjailed_warning("your perception function's"))


def _load_ik(args: argparse.Namespace) -> Any:
    """The user's IK for ``--ik SPEC`` (None without one), with ``--ik-timeout`` in a process of
    its own, jailed unless ``--no-jail``; a bad SPEC, or no jail where one can be made, is a
    one-line error here, before anything runs."""
    spec, timeout, root = args.ik, args.ik_timeout, getattr(args, "ik_root", None)
    if spec is None:
        if timeout is not None or root is not None:
            given = "--ik-timeout" if timeout is not None else "--ik-root"
            raise ConfigError(f"{given} needs --ik SPEC")
        return None
    from kr210_sim.sandbox.guarded import load_user_ik
    from kr210_sim.sandbox.user_ik import spec_root

    _no_jail(args)
    return load_user_ik(spec, timeout, root=None if root is None else spec_root(spec, root))


def _perception(args: argparse.Namespace) -> None:
    """Start ``--perception SPEC``'s process now (jailed unless ``--no-jail``), so a bad SPEC, or
    no jail where one can be made, is a one-line error before anything runs (the run takes the
    same process)."""
    from kr210_sim.api import _perception as start

    if args.perception is not None and args.ik is None:  # else _load_ik said it
        _no_jail(args)
    start(args.perceive, args.perception, args.perception_timeout)


def _duration(seconds: float) -> str:
    """A time [s] in the unit that reads best: us below 1 ms, ms below 1 s, else s."""
    if seconds < 1e-3:
        return f"{1e6 * seconds:.1f} us"
    if seconds < 1.0:
        return f"{1e3 * seconds:.1f} ms"
    return f"{seconds:.2f} s"


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


def run(args: argparse.Namespace) -> int:
    """``run``: run and score cycles, print the table and the outputs."""
    from kr210_sim.api import RunInterrupted, RunReport, run
    from kr210_sim.errors import VideoFailedError
    from kr210_sim.media.video import VideoSettings

    try:  # a bad SPEC is one line here, before anything runs
        ik = _load_ik(args)
        _perception(args)
    except KeyboardInterrupt as exc:  # one the user's module raises (signals wait for the job)
        from kr210_sim.sim.runner import RunConfig
        from kr210_sim.sim.session import unstarted_report
        from kr210_sim.util.outputs import check_writable, write_json_atomic

        config = RunConfig(cycles=args.cycles, seed=args.seed, slot=args.slot)
        write_json_atomic(check_writable(args.report), unstarted_report(config, exc))
        return exit_code(exc)
    watched = None
    if ik is not None:  # every answer the run asks for is kept, for the diagnosis
        from kr210_sim.grading.explain import Watched

        watched = Watched(ik)
        ik = watched.user_ik()
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
            out=cast(TextIO, EscapingStream(sys.stdout)),  # its lines quote the user's IK
            record=args.record,
            record_rate=args.record_rate or DEFAULT_RECORD_RATE,
            render_workers=args.render_workers,
            perceive=args.perceive,
            perception=args.perception,
            perception_timeout=args.perception_timeout,
        )
    except RunInterrupted as exc:
        interrupted, result = exc, exc.report  # type: ignore[assignment]
    except VideoFailedError as exc:
        result = exc.report
    assert isinstance(result, RunReport)
    _print_run(result, video)
    if watched is not None:
        _print_diagnosis(result, watched)
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
    """The summary table and the outputs of ``run`` on stdout (escaped: the table quotes the
    user's IK)."""
    from kr210_sim.score.report import summary_table

    out = EscapingStream(sys.stdout)
    summary = dict(result.summary)
    out.write(summary_table(summary) + "\n")
    if "ik" in summary:
        s, t = summary["ik"], summary["ik"]["wall_time_s"]
        out.write(
            f"  IK {s['spec']}: {s['calls']} calls, {_duration(t['per_call_mean'])} mean, "
            f"{_duration(t['per_call_max'])} max per call\n"
        )
        branches = s.get("branches", {})
        if branches.get("other_branch"):
            out.write(f"  IK branches: {branches['note']}\n")
    function = summary.get("perception", {}).get("function")
    if function is not None:
        out.write(
            f"  perception {function['spec']}: {function['looks']} "
            f"look{'' if function['looks'] == 1 else 's'} in "
            f"{function['confinement']}, {len(function['faults'])} faults\n"
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


def _print_diagnosis(result: RunReport, watched: Any) -> None:
    """The mistakes of the user's IK that the run's answers show, as ``grade`` names them; in
    the report too (``diagnosis``), when one was written."""
    from kr210_sim.grading.explain import finding_lines, run_findings
    from kr210_sim.robot.description import load_robot
    from kr210_sim.robot.kinematics import Kinematics
    from kr210_sim.util.outputs import write_json_atomic

    found = run_findings(Kinematics(load_robot()), watched, result.cycles)
    for line in finding_lines(found):
        sys.stdout.write(line + "\n")
    if result.path is not None and result.path.is_file():
        write_json_atomic(result.path, {**result.data, "diagnosis": [f.to_dict() for f in found]})


def replay(args: argparse.Namespace) -> int:
    """``replay REC``: render a recording to MP4."""
    from kr210_sim.media.replay import replay_job

    line = ProgressLine(sys.stderr)

    def progress(frames: int, sim_time: float, total: int | None) -> None:
        if line.due():
            of = f"/{total}" if total else ""
            line.show(f"replay: {frames}{of} frames  sim {sim_time:5.1f} s  {line.elapsed:4.0f} s")

    result = replay_job(
        args.recording, args.video, _video_options(args), args.scene, args.workers, progress
    )
    frames = result.frames
    line.end(f"replay: {frames} frames in {line.elapsed:.1f} s on {result.workers} worker(s)")
    written = f"({frames} frames)" if frames else "not written (no frames)"
    sys.stdout.write(f"  video: {result.video.path} {written}\n")
    if result.interrupted is not None:
        sys.stderr.write(
            f"kr210_sim: interrupted ({signal_name(result.interrupted)}); frames so far kept\n"
        )
        return exit_code(result.interrupted)
    return 0


def view(args: argparse.Namespace) -> int:
    """``view``: the cycles live in MuJoCo Studio (or a recording, or the joint sliders)."""
    from kr210_sim.jobs import view_job
    from kr210_sim.score.report import summary_table
    from kr210_sim.sim.runner import RunConfig
    from kr210_sim.view.live import LiveSettings, run_joints
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
    if args.joints or args.replay is not None:  # no report: the start-up ends here
        end_start_up()
    if args.joints:
        if args.demo:
            raise ConfigError("--joints has no task to step through: drop --demo")
        if args.replay is not None:
            raise ConfigError(
                "--joints poses the arm by hand; --replay plays a recording: drop one"
            )
        run_joints(settings, scene=args.scene, cell_file=args.cell)
        return 0
    if args.replay is not None:
        return _view_replay(args, settings)
    config = RunConfig(cycles=args.cycles, seed=args.seed, slot=args.slot, randomize=args.randomize)
    live = LiveSettings(speed=args.speed, exit_when_done=args.exit_when_done)
    ik = _load_ik(args)
    # A user's IK: its lines (and the table) may quote what it raised, escaped; no hyperlink.
    out = cast(TextIO, EscapingStream(sys.stdout)) if ik is not None else sys.stdout
    result = view_job(
        config, args.report, settings, live, scene=args.scene, ik=ik, cell=args.cell, out=out
    )
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
    from kr210_sim.media.replay import open_recording
    from kr210_sim.view.live import LiveSettings, replay_view

    if args.demo:
        raise ConfigError("--replay plays a recording: drop --demo")
    rec, model, _ = open_recording(args.replay, args.scene)
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


def evaluate(args: argparse.Namespace) -> int:
    """``evaluate``: Monte-Carlo evaluation over seeded episodes."""
    from kr210_sim.eval.evaluate import EvalConfig
    from kr210_sim.jobs import evaluate_job

    _no_jail(args)
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
        ik_timeout=args.ik_timeout,
        perceive=args.perceive,
        perception=args.perception,
        perception_timeout=args.perception_timeout,
    )
    perceiving = config.perceiving
    if isinstance(perceiving, tuple):  # a bad SPEC is one line here, before anything runs
        from kr210_sim.sandbox.perception_sandbox import open_perception

        open_perception(*perceiving)
    outcome = evaluate_job(config, args.report, args.resume, args.record_failures)
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
    ex = report["wall_execution"]
    where = f"{ex['workers']} worker(s), {ex['backend']}"
    if ex["backend"] == "ray":
        where += f" ({ex['nodes']} node(s), {ex['cpus']} CPUs)"
    resumed = f", {ex['resumed_episodes']} resumed" if ex["resumed_episodes"] else ""
    cycle_time = (
        f"mean {ct['mean']:.2f} s, p95 {ct['p95']:.2f} s, max {ct['max']:.2f} s"
        if s["successes"]
        else "none (no episode succeeded)"
    )
    if "perception" in s:
        from kr210_sim.score.report import recognised

        out.write(f"  recognised    {recognised(s['perception'], s['perception']['episodes'])}\n")
    out.write(
        f"  cycle time    {cycle_time}\n"
        f"  wall time     {ex['wall_time_s']:.1f} s on {where}{resumed}\n"
        f"  report: {outcome.report_path}\n  episodes: {outcome.episodes_path}\n"
    )
    if args.record_failures is not None and outcome.signal is None:
        from kr210_sim.eval.failures import record_failures

        made = record_failures(
            report["failed_episodes"],
            config.randomize,
            args.record_failures,
            config.cell or config.scene,
            ik=args.ik,
            ik_timeout=args.ik_timeout,
            perceive=config.perceiving,
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


def check(args: argparse.Namespace) -> int:
    """``check``: can every slot and drop spot of a cell be served?"""
    from kr210_sim.jobs import check_job

    result = check_job(args.scene, args.cell)
    sys.stdout.write(result.table() + "\n")
    return 0 if result.ok else 1


def ik_check(args: argparse.Namespace) -> int:
    """``ik-check --ik SPEC``: grade an IK function."""
    from kr210_sim.api import IkCheckReport, RunInterrupted, ik_check

    ik = _load_ik(args)  # a bad SPEC is one line here, before anything runs
    interrupted: RunInterrupted | None = None
    try:
        result = ik_check(ik, args.cases, args.seed, args.report, args.plots)
    except RunInterrupted as exc:
        interrupted, result = exc, exc.report  # type: ignore[assignment]
    assert isinstance(result, IkCheckReport)
    out = EscapingStream(sys.stdout)  # the text quotes what the user's IK raised
    out.write(result.text + "\n")
    out.write(f"  report: {args.report}\n")
    if result.plot_paths:
        out.write(f"  plots: {', '.join(str(p) for p in result.plot_paths)}\n")
    if interrupted is not None:
        return exit_code(interrupted)
    return 0 if result.passed else 1


def grade(args: argparse.Namespace) -> int:
    """``grade``: the leaderboard of a class; 0 when every student passed, 1 otherwise."""
    from kr210_sim.api import GradeReport, RunInterrupted, grade
    from kr210_sim.grading.course import CourseOutputs

    course = CourseOutputs(args.gradescope, args.csv)  # checked before anyone is graded
    course.check(args.submissions, {"--report": args.report, "--html": args.html})
    interrupted: RunInterrupted | None = None
    try:
        result = grade(
            args.submissions,
            cases=args.cases,
            cycles=args.cycles,
            seed=args.seed,
            timeout=args.timeout,
            ik_timeout=args.ik_timeout,
            memory_mb=args.memory,
            workers=args.workers,
            min_success=args.min_success,
            report=args.report,
            html=args.html,
            out=sys.stdout,
            jail=not args.no_jail,
        )
    except RunInterrupted as exc:
        interrupted, result = exc, exc.report  # type: ignore[assignment]
    assert isinstance(result, GradeReport)
    out = sys.stdout
    out.write(result.text + "\n")
    out.write(f"  report: {args.report}\n")
    if result.html_path is not None:
        out.write(f"  page: {result.html_path}\n")
    for line in course.write(result.data):
        out.write(f"  {line}\n")
    if interrupted is not None:
        return exit_code(interrupted)
    return 0 if result.passed else 1


def demos(args: argparse.Namespace) -> int:
    """``demos``: record the scripted expert in the Gymnasium environment."""
    from kr210_sim.envs.demos import record_demos

    s = record_demos(args.out, args.episodes, args.seed, args.control, args.randomize)
    sys.stdout.write(
        f"  episodes   {s.episodes}{' (interrupted)' if s.interrupted else ''} "
        f"({s.successes} succeeded)\n"
        f"  samples    {s.samples} policy steps\n  dataset: {s.path}\n"
    )
    return exit_code(s.interrupted) if s.interrupted is not None else 0


def build_scene(args: argparse.Namespace) -> int:
    """``build-scene``: regenerate scenes/ from the URDF and the cell spec."""
    from kr210_sim.cell.mjcf import build_scene

    for path in build_scene(args.out):
        print(f"wrote {path}")
    return 0


def build_meshes(args: argparse.Namespace) -> int:
    """``build-meshes``: regenerate the KR210 meshes."""
    from kr210_sim.robot.meshes import build_meshes

    paths = build_meshes(args.out) if args.out else build_meshes()
    print(f"wrote {len(paths)} meshes to {paths[0].parent if paths else args.out}")
    return 0


def snapshot(args: argparse.Namespace) -> int:
    """``snapshot``: render a still of the cell offscreen."""
    from kr210_sim.jobs import snapshot_job

    path = snapshot_job(args.out, args.camera, args.width, args.height, args.cell)
    print(f"wrote {path}")
    return 0


def perceive(args: argparse.Namespace) -> int:
    """``perceive``: look at the first cycle's target of ``run --perceive --cycles 1`` and draw
    each look (colour, depth, the clusters labelled with their poses) into one PNG."""
    from kr210_sim.media.look_panels import write_look_panels
    from kr210_sim.sensors.glance import glance
    from kr210_sim.util.outputs import check_distinct, check_writable, is_stream
    from kr210_sim.util.paths import SCENE_PATH

    check_writable(args.out)
    check_distinct({"--out": args.out}, {"--cell": args.cell, "the scene": SCENE_PATH})
    if args.out.suffix.lower() != ".png" and not is_stream(args.out):
        raise ConfigError(f"--out {args.out}: perceive writes a PNG; give a path ending in .png")
    g = glance(args.cell, args.seed, args.slot, args.randomize)
    r = g.record
    labels = write_look_panels(args.out, g.observations, g.percept, f"slot {g.slot}: {g.label}?")
    if r.seen:
        axis = f", axis {r.axis_error_deg:.1f} deg" if r.axis_error_deg is not None else ""
        off = f"{r.position_error_mm:.1f} mm off{axis}" if r.position_error_mm is not None else ""
        on = "the target" if r.right_object else "ANOTHER object"
        print(f"  {r.label} seen in slot {g.slot} ({r.confidence:.2f} sure) on {on}: {off}")
    else:
        print(f"  {r.label} not seen in slot {g.slot}: {r.reason}")
    print(f"  {len(g.observations)} look(s), clusters {list(r.clusters)}, {len(labels)} labelled")
    print(f"wrote {args.out}")
    return 0


def train_recogniser(args: argparse.Namespace) -> int:
    """``train-recogniser``: train perception's recogniser on a cell's rendered scenes and write
    its model file (what ``run --perceive`` trains and caches by itself for a cell of kinds the
    shipped model does not know; the shipped model is this on the cluttered example cell)."""
    from kr210_sim.cell.load import model_at
    from kr210_sim.sensors.recognisers import train_for
    from kr210_sim.util.outputs import check_writable, commit, temp_beside

    check_writable(args.out)
    if args.cell.suffix.lower() != ".toml":
        raise ConfigError(f"--cell {args.cell}: give a cell file (.toml)")
    trained = train_for(model_at(args.cell), args.scenes, args.seed)
    tmp = temp_beside(args.out)
    tmp.write_text(trained.to_json(), encoding="utf-8")
    commit(tmp, args.out)
    counts = ", ".join(f"{k} {trained.y.count(k)}" for k in sorted(set(trained.y)))
    print(f"wrote {args.out}: {len(trained.y)} clusters of {args.scenes} scenes ({counts})")
    return 0
