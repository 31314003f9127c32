"""Command-line interface: ``python -m kr210_sim <command>``.

Commands: ``run`` (the main job), ``replay`` (render a recording of a run to MP4), ``view`` (the
same run live in MuJoCo Studio), ``evaluate``, ``ik-check``, ``check``, ``demos``, ``build-meshes``,
``build-scene``, ``snapshot``. Exit codes: 0 success, 1 a run below its pass bar (or an IK failing a
case), 2 a usage error or a failure with a one-line message, 130 interrupted by Ctrl-C, 143 by
SIGTERM, 129 by SIGHUP (the report of the cycles completed so far is still written).

This module is the argument parser and the error handling; what each command does and prints is
in :mod:`kr210_sim.commands`.
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeAlias

import kr210_sim.shadowed  # noqa: F401  (first: exits in one line when kr210_sim is shadowed)
from kr210_sim import __version__, commands
from kr210_sim.commands import DEFAULT_RECORD_RATE
from kr210_sim.errors import Kr210SimError
from kr210_sim.util import argtypes
from kr210_sim.util.console import EscapingFormatter, SafeStream, escape
from kr210_sim.util.interrupts import (
    end_start_up,
    exit_code,
    hold_start_up,
    is_the_command,
    leaving,
    received,
    signal_name,
    terminate_as_interrupt,
    work_done,
)

DEFAULT_REPORT = Path("reports/run.json")
DEFAULT_EVAL_REPORT = Path("reports/evaluate.json")
DEFAULT_IK_REPORT = Path("reports/ik_check.json")
DEFAULT_VIEW_REPORT = Path("reports/view.json")
DEFAULT_GRADE_REPORT = Path("reports/grade.json")
DEFAULT_DEMOS = Path("demos/pick_place.hdf5")


class _Parser(argparse.ArgumentParser):
    """An argparse parser whose usage errors are one line and exit code 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        sys.stderr.write(f"{self.prog}: error: {message}\n")
        raise SystemExit(2)


class _Version(argparse.Action):
    """``--version``: the package's version, then what it runs on (worked out only when asked:
    which IK path one pose takes is known once the kinematics are imported, which the parser's
    start-up does not do)."""

    def __init__(self, option_strings: list[str], dest: str, **kwargs: Any) -> None:
        super().__init__(option_strings, dest, nargs=0, help="show the version and exit")

    def __call__(self, parser: argparse.ArgumentParser, *args: Any, **kwargs: Any) -> None:
        import platform

        import mujoco
        import numpy

        from kr210_sim.robot.ik_scalar import which_path

        sys.stdout.write(
            f"kr210_sim {__version__}\n"
            f"MuJoCo {mujoco.__version__}, numpy {numpy.__version__}, "
            f"Python {platform.python_version()}\n"
            f"inverse kinematics of one pose: {which_path()}\n"
        )
        parser.exit()


def _cycles(text: str) -> int:
    from kr210_sim.sim.runner import MAX_CYCLES

    value = argtypes.positive_int(text)
    argtypes.check(
        value <= MAX_CYCLES, f"at most {MAX_CYCLES} in one run (use evaluate), got {value}"
    )
    return value


# One function per command adds that command's parser (``_add_<command>``, listed in
# ``_COMMANDS`` in the order ``--help`` shows them); the ``_add_*_option(s)`` helpers add the
# options several commands share, each command naming its own help text where it differs.

#: The object ``add_subparsers`` returns, that each ``_add_<command>`` adds its parser to.
_Commands: TypeAlias = "argparse._SubParsersAction[_Parser]"


def _add_scene_option(cmd: argparse.ArgumentParser) -> None:
    cmd.add_argument("--scene", type=Path, default=None, help="MJCF scene (scenes/kr210_cell.xml)")


def _add_cell_option(cmd: argparse.ArgumentParser, instead: str = "--scene") -> None:
    cmd.add_argument(
        "--cell",
        type=Path,
        default=None,
        metavar="PATH",
        help=f"cell file (TOML), e.g. scenes/cells/published.toml; compiled instead of {instead}",
    )


def _add_seed_option(cmd: argparse.ArgumentParser, of: str) -> None:
    """``--seed`` (default 0); ``of`` completes its help ("seed of ...")."""
    cmd.add_argument("--seed", type=argtypes.seed, default=0, help=f"seed of {of} (0)")


def _add_report_option(cmd: argparse.ArgumentParser, default: Path, label: str) -> None:
    """``--report``, its help ``label`` followed by the default path."""
    cmd.add_argument("--report", type=Path, default=default, help=f"{label} ({default})")


def _add_min_success_option(cmd: argparse.ArgumentParser, default: float, help: str) -> None:
    cmd.add_argument("--min-success", type=argtypes.fraction, default=default, help=help)


def _add_workers_option(cmd: argparse.ArgumentParser, help: str) -> None:
    cmd.add_argument("--workers", type=argtypes.positive_int, default=None, help=help)


def _add_plots_option(cmd: argparse.ArgumentParser) -> None:
    cmd.add_argument("--plots", type=Path, default=None, help="write PNG plots into this folder")


def _add_ik_options(
    cmd: argparse.ArgumentParser, ik: str, timeout: str, required: bool = False, root: bool = True
) -> None:
    """``--ik SPEC``, ``--ik-timeout S`` and (with ``root``) ``--ik-root DIR``, with the help
    texts ``ik`` and ``timeout``."""
    if required:
        cmd.add_argument("--ik", required=True, metavar="SPEC", help=ik)
    else:
        cmd.add_argument("--ik", default=None, metavar="SPEC", help=ik)
    cmd.add_argument("--ik-timeout", type=argtypes.seconds, default=None, metavar="S", help=timeout)
    if root:
        cmd.add_argument(
            "--ik-root",
            type=Path,
            default=None,
            metavar="DIR",
            help="with --ik-timeout: the folder of your own files the jail shows your code "
            "(default: a file SPEC's file alone), as grade shows a folder student",
        )
    _add_no_jail_option(cmd, "run --ik-timeout's process unjailed (says what is then unprotected)")


def _add_no_jail_option(cmd: argparse.ArgumentParser, help: str) -> None:
    cmd.add_argument("--no-jail", action="store_true", help=help)


def _add_run_options(cmd: argparse.ArgumentParser, report: Path) -> None:
    """The options ``run`` and ``view`` share."""
    cmd.add_argument("--cycles", type=_cycles, default=10, help="cycles to run (10)")
    _add_seed_option(cmd, "the run's generator")
    slot = "slot 1-9 (bottom row first), 0 = random per cycle (0)"
    cmd.add_argument("--slot", type=argtypes.slot, default=0, help=slot)
    drawn = "randomise target pose, size, mass and friction per cycle"
    cmd.add_argument("--randomize", action="store_true", help=drawn)
    _add_report_option(cmd, report, "JSON report path")
    _add_min_success_option(cmd, 0.8, "pass bar: exit 1 below this success rate (0.8)")
    _add_scene_option(cmd)
    _add_cell_option(cmd)
    _add_ik_options(
        cmd,
        ik="plan with your IK: package.module:function or path/to/file.py:function",
        timeout="run --ik in its own process; no answer within S seconds: that cycle is ik_failed",
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
    for side, px in (("width", 640), ("height", 480)):
        size = f"video {side} [px] ({px})"
        cmd.add_argument(f"--{side}", type=argtypes.multiple_of_16, default=None, help=size)
    cmd.add_argument(
        "--fps", type=argtypes.fps, default=None, help=f"video frames per simulated s ({fps})"
    )
    cmd.add_argument(
        "--quality",
        choices=("fast", "medium", "high"),
        default=None,
        help="fast: no shadows; medium: shadows (default); high: big shadow map, 4x MSAA",
    )


def _add_run(sub: _Commands) -> None:
    cmd = sub.add_parser("run", help="run and score pick-and-place cycles")
    _add_run_options(cmd, DEFAULT_REPORT)
    cmd.add_argument("--video", type=Path, default=None, help="write an MP4 of the run here")
    _add_video_options(cmd, "overview", "30")
    _add_plots_option(cmd)
    cmd.add_argument(
        "--record", type=Path, default=None, help="write a recording of the run (.npz) here"
    )
    cmd.add_argument(
        "--record-rate",
        type=argtypes.fps,
        help=f"recorded states per simulated s ({DEFAULT_RECORD_RATE})",
    )
    cmd.add_argument(
        "--render-workers",
        type=argtypes.positive_int,
        default=None,
        help="processes rendering the video (one per core; 1: render in this process)",
    )
    _add_perception_options(cmd)
    cmd.set_defaults(func=commands.run)


def _add_perception_options(cmd: argparse.ArgumentParser) -> None:
    """``--perceive``, ``--perception SPEC`` and ``--perception-timeout S``."""
    cmd.add_argument("--perceive", action="store_true", help="pick from what the sensors see")
    cmd.add_argument(
        "--perception",
        default=None,
        metavar="SPEC",
        help="with --perceive, your perception in place of ours, jailed: "
        "package.module:function or path/to/file.py:function",
    )
    per_look = "time --perception's function may take per look (10)"
    kind = argtypes.seconds
    cmd.add_argument("--perception-timeout", type=kind, default=None, metavar="S", help=per_look)


def _add_replay(sub: _Commands) -> None:
    cmd = sub.add_parser("replay", help="render a recording (run --record) to MP4")
    cmd.add_argument("recording", type=Path, metavar="REC", help="the recording (.npz)")
    cmd.add_argument("--video", type=Path, default=None, help="MP4 path (default: REC with .mp4)")
    _add_video_options(cmd, "the run's, else overview", "the recording's rate")
    _add_workers_option(cmd, "render processes (one per core; 1: render in this process)")
    cmd.add_argument(
        "--scene",
        type=Path,
        default=None,
        help="MJCF scene the recording was made with (default: the one it names, else ours)",
    )
    cmd.set_defaults(func=commands.replay)


def _add_viewer_options(cmd: argparse.ArgumentParser) -> None:
    """``view``'s own options: where it shows, how and what."""
    where = cmd.add_mutually_exclusive_group()
    where.add_argument(
        "--web",
        action="store_true",
        help="serve the viewer to a browser (the default without a display)",
    )
    where.add_argument(
        "--window", action="store_true", help="open a native window (needs a display)"
    )
    cmd.add_argument(
        "--port", type=argtypes.port, default=0, help="web viewer port (0: first free from 8080)"
    )
    cmd.add_argument(
        "--host",
        default="127.0.0.1",
        help="interface to listen on (127.0.0.1); 0.0.0.0 exposes the unauthenticated viewer",
    )
    cmd.add_argument(
        "--camera", default=None, help="start on a named camera (default: orbit from overview)"
    )
    cmd.add_argument(
        "--demo", action="store_true", help="pause before every phase until Next (key N)"
    )
    cmd.add_argument(
        "--joints", action="store_true", help="no task: pose the arm with six joint sliders"
    )
    cmd.add_argument(
        "--quality",
        choices=("full", "fast"),
        default="full",
        help="fast: no shadows, reflections or haze (for software WebGL)",
    )
    cmd.add_argument(
        "--speed", type=argtypes.speed, default=1.0, help="simulated seconds per wall second (1)"
    )


def _add_view(sub: _Commands) -> None:
    cmd = sub.add_parser("view", help="watch the cycles live in MuJoCo Studio (browser or window)")
    _add_run_options(cmd, DEFAULT_VIEW_REPORT)
    _add_viewer_options(cmd)
    cmd.add_argument(
        "--replay",
        type=Path,
        default=None,
        metavar="REC",
        help="play a recording (run --record) instead of running the cycles",
    )
    cmd.add_argument(
        "--exit-when-done",
        action="store_true",
        help="exit when the cycles are done (default: keep showing until Ctrl-C)",
    )
    cmd.set_defaults(func=commands.view)


def _add_evaluate(sub: _Commands) -> None:
    cmd = sub.add_parser("evaluate", help="Monte-Carlo evaluation over many seeded episodes")
    cmd.add_argument("--episodes", type=argtypes.positive_int, default=100, help="episodes (100)")
    _add_workers_option(cmd, "local processes (1), or Ray tasks in flight (the cluster's CPUs)")
    cmd.add_argument(
        "--backend",
        choices=("local", "ray"),
        default="local",
        help="local: processes on this machine (default); ray: a Ray cluster",
    )
    cmd.add_argument(
        "--address",
        default=None,
        help="Ray cluster to use: auto or HOST:PORT (default: start Ray on this machine)",
    )
    cmd.add_argument(
        "--resume",
        action="store_true",
        help="continue from the episodes file beside --report, skipping episodes done",
    )
    _add_seed_option(cmd, "the episode seeds")
    cmd.add_argument("--randomize", action="store_true", help="randomise each episode's target")
    _add_perception_options(cmd)
    _add_scene_option(cmd)
    _add_cell_option(cmd)
    _add_ik_options(
        cmd,
        ik="plan every episode with your IK: package.module:function or path/to/file.py:function",
        timeout="run --ik in its own process; no answer within S seconds: the episode is ik_failed",
        root=False,
    )
    _add_report_option(cmd, DEFAULT_EVAL_REPORT, "JSON report path")
    _add_min_success_option(cmd, 0.995, "pass bar for exit 0 (0.995)")
    cmd.add_argument(
        "--record-failures",
        type=Path,
        default=None,
        metavar="DIR",
        help="record every failed episode as DIR/<seed>_<reason>.npz (replay renders it)",
    )
    cmd.set_defaults(func=commands.evaluate)


def _add_check(sub: _Commands) -> None:
    cmd = sub.add_parser("check", help="can every slot and drop spot of a cell be served?")
    _add_scene_option(cmd)
    _add_cell_option(cmd)
    cmd.set_defaults(func=commands.check)


def _add_ik_check(sub: _Commands) -> None:
    cmd = sub.add_parser("ik-check", help="grade an IK function on fixed and random poses")
    _add_ik_options(
        cmd,
        ik="package.module:function or path/to/file.py:function (ours: "
        "kr210_sim.robot.kinematics:nearest)",
        timeout="run --ik in a process of its own; no answer within S seconds fails the case",
        required=True,
    )
    cmd.add_argument(
        "--cases",
        type=argtypes.count,
        default=1000,
        help="random poses on top of the fixed set (1000)",
    )
    _add_seed_option(cmd, "the random poses")
    _add_report_option(cmd, DEFAULT_IK_REPORT, "JSON report path")
    _add_plots_option(cmd)
    cmd.set_defaults(func=commands.ik_check)


def _add_grade(sub: _Commands) -> None:
    cmd = sub.add_parser("grade", help="grade many students' IK solutions, each in a sandbox")
    cmd.add_argument(
        "submissions",
        nargs="+",
        metavar="SUBMISSION",
        help="a folder (each .py file or subfolder is a student), a .py file or a SPEC",
    )
    cmd.add_argument(
        "--cases", type=argtypes.count, default=1000, help="random ik-check poses (1000)"
    )
    cmd.add_argument("--cycles", type=_cycles, default=10, help="cycles of each run (10)")
    _add_seed_option(cmd, "the poses and the runs")
    cmd.add_argument(
        "--timeout", type=argtypes.seconds, default=120.0, help="seconds per student (120)"
    )
    cmd.add_argument(
        "--ik-timeout", type=argtypes.seconds, default=2.0, help="seconds per IK call (2)"
    )
    cmd.add_argument(
        "--memory", type=argtypes.positive_int, default=1024, help="MB of memory per student (1024)"
    )
    _add_workers_option(cmd, "students at once (one per core)")
    _add_min_success_option(cmd, 0.8, "the run's pass bar (0.8: 8 of 10)")
    _add_report_option(cmd, DEFAULT_GRADE_REPORT, "JSON report")
    cmd.add_argument("--html", type=Path, default=None, help="write the leaderboard page here")
    cmd.add_argument(
        "--gradescope",
        type=Path,
        default=None,
        metavar="FILE",
        help="write Gradescope's results.json here (one submission)",
    )
    cmd.add_argument(
        "--csv", type=Path, default=None, metavar="FILE", help="write a gradebook CSV here"
    )
    _add_no_jail_option(cmd, "run the students' code unjailed (says what is then unprotected)")
    cmd.set_defaults(func=commands.grade)


def _add_demos(sub: _Commands) -> None:
    cmd = sub.add_parser(
        "demos", help="record the scripted expert in the Gymnasium environment (HDF5 dataset)"
    )
    cmd.add_argument("--episodes", type=argtypes.positive_int, default=10, help="episodes (10)")
    cmd.add_argument("--out", type=Path, default=DEFAULT_DEMOS, help=f"HDF5 file ({DEFAULT_DEMOS})")
    cmd.add_argument(
        "--control", choices=("joint", "cartesian"), default="joint", help="action space (joint)"
    )
    cmd.add_argument(
        "--seed", type=argtypes.seed, default=0, help="episode i is seeded seed + i (0)"
    )
    cmd.add_argument("--randomize", action="store_true", help="randomise the cylinders")
    cmd.set_defaults(func=commands.demos)


def _add_build_scene(sub: _Commands) -> None:
    cmd = sub.add_parser("build-scene", help="regenerate scenes/ from the URDF and the config")
    cmd.add_argument("--out", type=Path, default=None, help="output folder (scenes/)")
    cmd.set_defaults(func=commands.build_scene)


def _add_build_meshes(sub: _Commands) -> None:
    cmd = sub.add_parser("build-meshes", help="regenerate the KR210 meshes")
    cmd.add_argument("--out", type=Path, default=None, help="output folder")
    cmd.set_defaults(func=commands.build_meshes)


def _add_snapshot(sub: _Commands) -> None:
    cmd = sub.add_parser("snapshot", help="render a still of the cell offscreen")
    cmd.add_argument("--camera", default="overview", help="camera name (overview)")
    cmd.add_argument("--out", type=Path, default=Path("cell.png"), help="PNG path (cell.png)")
    cmd.add_argument("--width", type=argtypes.positive_int, default=1280, help="width [px] (1280)")
    cmd.add_argument("--height", type=argtypes.positive_int, default=720, help="height [px] (720)")
    _add_cell_option(cmd, "the committed scene")
    cmd.set_defaults(func=commands.snapshot)


def _add_perceive(sub: _Commands) -> None:
    cmd = sub.add_parser("perceive", help="look at a cycle's target and draw what was seen (PNG)")
    cmd.add_argument("--out", type=Path, default=Path("look.png"), help="PNG path (look.png)")
    _add_cell_option(cmd, "the committed scene")
    _add_seed_option(cmd, "the cycle's slot, target and clutter (as run --cycles 1)")
    cmd.add_argument("--slot", type=argtypes.slot, default=0, help="slot 1-9, 0 = drawn (0)")
    cmd.add_argument("--randomize", action="store_true", help="randomise as run --randomize")
    cmd.set_defaults(func=commands.perceive)


def _add_train_recogniser(sub: _Commands) -> None:
    cmd = sub.add_parser("train-recogniser", help="train perception's recogniser on a cell")
    cmd.add_argument("--cell", type=Path, required=True, metavar="PATH", help="cell file (TOML)")
    cmd.add_argument("--out", type=Path, required=True, help="the model file to write (JSON)")
    _add_seed_option(cmd, "the rendered scenes")
    cmd.add_argument("--scenes", type=argtypes.positive_int, default=120, help="scenes (120)")
    cmd.set_defaults(func=commands.train_recogniser)


#: The commands in the order ``--help`` lists them.
_COMMANDS: tuple[Callable[[_Commands], None], ...] = (
    _add_run,
    _add_replay,
    _add_view,
    _add_evaluate,
    _add_check,
    _add_ik_check,
    _add_grade,
    _add_demos,
    _add_build_scene,
    _add_build_meshes,
    _add_snapshot,
    _add_perceive,
    _add_train_recogniser,
)


def build_parser() -> argparse.ArgumentParser:
    """The CLI's argument parser: the global options, then each command's parser."""
    parser = _Parser(prog="kr210_sim", description="KUKA KR210 pick-and-place cell in MuJoCo.")
    parser.add_argument("--version", action=_Version)
    parser.add_argument("-v", "--verbose", action="store_true", help="log what the cell does")
    sub = parser.add_subparsers(dest="command", parser_class=_Parser, metavar="COMMAND")
    sub.required = True
    for add in _COMMANDS:
        add(sub)
    return parser


#: Commands whose job ends the start-up's hold itself (``interrupts.end_start_up``), where its
#: own handling of an interrupt begins: a signal during the start-up gives their report of no
#: cycles (grade's: of no students). The others end it before they are called, and write
#: nothing for such a signal.
_OWN_START = frozenset({"run", "view", "grade"})


def main(argv: list[str] | None = None) -> int:
    """Run the CLI and return its exit code.

    While a command runs, stdout and stderr are :class:`~kr210_sim.util.console.SafeStream`
    objects (a closed pipe or a full device drops console output, never the run) and SIGTERM /
    SIGHUP stop it like Ctrl-C (:mod:`kr210_sim.util.interrupts`): exit 130, 143 or 129. The
    signals are held from the start (imports, parsing) until the command's work begins, and
    again once it is over; after the first, every further one is held while the report of what
    was done is written.
    """
    hold_start_up()  # already held since the package's first import when this is the command
    stdout, stderr = sys.stdout, sys.stderr
    sys.stdout, sys.stderr = SafeStream(stdout, "stdout"), SafeStream(stderr, "stderr")
    try:
        with terminate_as_interrupt():
            try:
                code = _main(argv)
                work_done()
            except KeyboardInterrupt as exc:  # as the command's work began, or ended
                work_done()
                sys.stderr.write(f"kr210_sim: interrupted ({signal_name(exc)})\n")
                code = exit_code(exc)
            signum = received()
            if signum is not None and code < 128:  # an interrupt something swallowed, or late
                sys.stderr.write(f"kr210_sim: interrupted ({signal.Signals(signum).name})\n")
                code = 128 + signum
            sys.stdout.flush()
            if is_the_command():
                leaving(code)
            return code
    finally:
        sys.stdout.flush()
        sys.stdout, sys.stderr = stdout, stderr


def _main(argv: list[str] | None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    log_lines = logging.StreamHandler(sys.stderr)  # a log line may quote a user's IK: escaped
    log_lines.setFormatter(EscapingFormatter("%(levelname)s %(name)s: %(message)s"))
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING, handlers=[log_lines]
    )
    # Every path is resolved now, before any user code runs: an IK that changes the working
    # folder (os.chdir) must not move where the outputs go or which inputs are read.
    for key, value in vars(args).items():
        if isinstance(value, Path):
            setattr(args, key, value.absolute())
    if getattr(args, "out", "") is None and args.command == "build-scene":
        from kr210_sim.util.paths import SCENES_DIR

        args.out = SCENES_DIR
    if args.command not in _OWN_START:
        try:
            end_start_up()
        except KeyboardInterrupt as exc:
            sys.stderr.write(
                f"kr210_sim: interrupted ({signal_name(exc)}) before {args.command} began; "
                "nothing written\n"
            )
            return exit_code(exc)
    try:
        return int(args.func(args))
    except Kr210SimError as exc:
        if received() is not None:  # the error came of an interrupt (main() reports it)
            return 2
        table = getattr(exc, "table", None)
        if table:
            sys.stderr.write(escape(table, lines=True) + "\n")
        sys.stderr.write(f"kr210_sim: error: {escape(str(exc))}\n")  # may quote a user's IK
        return 2
    except KeyboardInterrupt as exc:
        sys.stderr.write(f"kr210_sim: interrupted ({signal_name(exc)})\n")
        return exit_code(exc)
