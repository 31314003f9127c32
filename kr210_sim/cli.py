"""Command-line interface: ``python -m kr210_sim <command>``.

Commands: ``run`` (the main job), ``build-meshes``, ``build-scene``, ``snapshot``. Exit codes:
0 success, 1 a run below its pass bar, 2 a usage error or a failure with a one-line message,
130 interrupted (the report of the work completed so far is still written; 143 when `evaluate`
is stopped by SIGTERM).
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
from pathlib import Path
from typing import Any

from kr210_sim import __version__
from kr210_sim.errors import ConfigError, Kr210SimError

DEFAULT_REPORT = Path("reports/run.json")
DEFAULT_EVAL_REPORT = Path("reports/evaluate.json")


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


def _slot(text: str) -> int:
    value: int = _parsed(text, int, "0-9")
    _check(0 <= value <= 9, f"must be 0 (random) or 1-9, got {value}")
    return value


def _fraction(text: str) -> float:
    value: float = _parsed(text, float, "a number in [0, 1]")
    _check(0.0 <= value <= 1.0, f"must be in [0, 1], got {value}")
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


def _cmd_run(args: argparse.Namespace) -> int:
    from kr210_sim.job import run_job
    from kr210_sim.report import summary_table
    from kr210_sim.runner import RunConfig
    from kr210_sim.video import VideoSettings

    config = RunConfig(cycles=args.cycles, seed=args.seed, slot=args.slot, randomize=args.randomize)
    video = None
    # The video options given on the command line; VideoSettings holds the defaults.
    given: dict[str, Any] = {
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
    if args.video is not None:
        video = VideoSettings(path=args.video, **given)
    elif given:
        raise ConfigError("--camera, --width, --height, --fps and --quality need --video PATH")
    job = run_job(config, args.report, video=video, plots_dir=args.plots, scene=args.scene)
    out = sys.stdout
    summary = job.report["summary"]
    out.write(summary_table(summary) + "\n")
    out.write(f"  report: {job.report_path}\n")
    if video is not None and job.video_error is None:
        out.write(f"  video: {video.path} ({job.video_frames} frames)\n")
    if job.plot_paths:
        out.write(f"  plots: {', '.join(str(p) for p in job.plot_paths)}\n")
    if job.video_error is not None:
        sys.stderr.write(f"kr210_sim: error: {job.video_error} (the report was written)\n")
        return 2
    if job.interrupted:
        return 130
    passed = summary["success_rate"] >= args.min_success
    out.write(
        f"{'PASS' if passed else 'FAIL'}: {summary['successes']}/{summary['cycles']} "
        f"cycles succeeded (pass bar {args.min_success:.0%})\n"
    )
    return 0 if passed else 1


def _cmd_evaluate(args: argparse.Namespace) -> int:
    from kr210_sim.evaluate import EvalConfig, evaluate
    from kr210_sim.report import check_writable
    from kr210_sim.scene import load_model

    config = EvalConfig(
        episodes=args.episodes,
        seed=args.seed,
        randomize=args.randomize,
        workers=args.workers,
        scene=args.scene,
        backend=args.backend,
        address=args.address,
    )
    if config.backend == "ray":
        from importlib.util import find_spec

        from kr210_sim.eval_ray import INSTALL_HINT

        if find_spec("ray") is None:
            raise ConfigError(INSTALL_HINT)
    check_writable(args.report)
    load_model(args.scene)  # a bad scene fails here, before any worker starts
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


def _cmd_build_scene(args: argparse.Namespace) -> int:
    from kr210_sim.scene import build_scene

    for path in build_scene(args.out):
        print(f"wrote {path}")
    return 0


def _cmd_build_meshes(args: argparse.Namespace) -> int:
    from kr210_sim.meshes import build_meshes

    paths = build_meshes(args.out) if args.out else build_meshes()
    print(f"wrote {len(paths)} meshes to {paths[0].parent if paths else args.out}")
    return 0


def _cmd_snapshot(args: argparse.Namespace) -> int:
    from kr210_sim.render import snapshot

    path = snapshot(args.out, camera=args.camera, width=args.width, height=args.height)
    print(f"wrote {path}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The CLI's argument parser."""
    parser = _Parser(prog="kr210_sim", description="KUKA KR210 pick-and-place cell in MuJoCo.")
    parser.add_argument("--version", action="version", version=f"kr210_sim {__version__}")
    parser.add_argument("-v", "--verbose", action="store_true", help="log what the cell does")
    sub = parser.add_subparsers(dest="command", parser_class=_Parser, metavar="COMMAND")
    sub.required = True

    run = sub.add_parser("run", help="run and score pick-and-place cycles")
    run.add_argument("--cycles", type=_positive_int, default=10, help="cycles to run (10)")
    run.add_argument("--seed", type=_seed, default=0, help="seed of the run's generator (0)")
    run.add_argument(
        "--slot",
        type=_slot,
        default=0,
        help="slot 1-9 (bottom row first), 0 = random per cycle (0)",
    )
    run.add_argument(
        "--randomize",
        action="store_true",
        help="randomise target pose, size, mass and friction per cycle",
    )
    run.add_argument(
        "--report", type=Path, default=DEFAULT_REPORT, help=f"JSON report path ({DEFAULT_REPORT})"
    )
    run.add_argument(
        "--min-success",
        type=_fraction,
        default=0.8,
        help="pass bar: exit 1 below this success rate (0.8)",
    )
    run.add_argument("--scene", type=Path, default=None, help="MJCF scene (scenes/kr210_cell.xml)")
    run.add_argument("--video", type=Path, default=None, help="write an MP4 of the run here")
    run.add_argument(
        "--camera",
        action="append",
        default=None,
        help="camera for the video (overview); repeat to tile views side by side",
    )
    run.add_argument("--width", type=_multiple_of_16, default=None, help="video width [px] (640)")
    run.add_argument("--height", type=_multiple_of_16, default=None, help="video height [px] (480)")
    run.add_argument("--fps", type=_fps, default=None, help="video frames per simulated s (30)")
    run.add_argument(
        "--quality",
        choices=("fast", "medium", "high"),
        default=None,
        help="fast: no shadows; medium: shadows (default); high: big shadow map, 4x MSAA",
    )
    run.add_argument("--plots", type=Path, default=None, help="write PNG plots into this folder")
    run.set_defaults(func=_cmd_run)

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
    ev.add_argument(
        "--report",
        type=Path,
        default=DEFAULT_EVAL_REPORT,
        help=f"JSON report path ({DEFAULT_EVAL_REPORT})",
    )
    ev.add_argument(
        "--min-success", type=_fraction, default=0.995, help="pass bar for exit 0 (0.995)"
    )
    ev.set_defaults(func=_cmd_evaluate)

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
    snap.set_defaults(func=_cmd_snapshot)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the CLI and return its exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING,
        format="%(levelname)s %(name)s: %(message)s",
    )
    if getattr(args, "out", "") is None and args.command == "build-scene":
        from kr210_sim.paths import SCENES_DIR

        args.out = SCENES_DIR
    try:
        return int(args.func(args))
    except Kr210SimError as exc:
        sys.stderr.write(f"kr210_sim: error: {exc}\n")
        return 2
    except KeyboardInterrupt:
        sys.stderr.write("kr210_sim: interrupted\n")
        return 130
