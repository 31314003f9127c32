"""The Python API: run, evaluate and check an IK, and grade a class, from a script, a notebook or
a sweep.

The command line is a thin layer over these functions (``python -m kr210_sim run`` calls
:func:`run`), so a call returns exactly the figures the command prints and the JSON it writes::

    import kr210_sim

    report = kr210_sim.run(cycles=3, seed=1)
    report.summary["success_rate"]           # 1.0
    [c.reason for c in report.cycles]        # [None, None, None]
    report.to_json()                          # the text `run --report` writes

Errors are exceptions of :mod:`kr210_sim.errors` (a bad argument is a
:class:`~kr210_sim.errors.ConfigError` with one sentence). Two outcomes keep the run's report
on the exception, because the cycles that finished are worth having:

* Ctrl-C or SIGTERM during the cycles (or episodes, or students) raises
  :class:`RunInterrupted` (a :class:`KeyboardInterrupt`) after the report of those finished
  was written; its ``report`` holds them.
* A video that could not be made raises :class:`~kr210_sim.errors.VideoFailedError` after the
  cycles ran and the report was written; its ``report`` holds the run.

Per-cycle lines go to ``out`` when one is given (the CLI passes stdout), else to the logger
``kr210_sim.api`` at INFO. The environment for learning is in :mod:`kr210_sim.envs`.
"""

from __future__ import annotations

import logging
import signal
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

import numpy as np

from kr210_sim.errors import ConfigError, VideoFailedError
from kr210_sim.results import (
    EvalReport,
    GradeReport,
    IkCheckReport,
    Report,
    RunInterrupted,
    RunReport,
)

if TYPE_CHECKING:
    from kr210_sim.media.video import VideoSettings
    from kr210_sim.sandbox.user_ik import UserIk

__all__ = [
    "EvalReport",
    "GradeReport",
    "IkCheckReport",
    "Report",
    "RunInterrupted",
    "RunReport",
    "as_user_ik",
    "evaluate",
    "grade",
    "ik_check",
    "run",
]

log = logging.getLogger(__name__)


def as_user_ik(ik: str | Callable[..., Any] | UserIk | None) -> UserIk | None:
    """The :class:`~kr210_sim.sandbox.user_ik.UserIk` for an ``ik=`` argument.

    Args:
        ik: ``"package.module:function"`` or ``"path/to/file.py:function"`` (loaded as
            ``--ik`` loads it), a callable with the ``solve(T, q_ref)`` contract, a loaded
            :class:`UserIk`, or None for our closed form.

    Raises:
        IkSpecError: When the SPEC names nothing loadable, or ``ik`` is neither a string nor a
            callable.
    """
    from kr210_sim.sandbox.user_ik import UserIk, ik_from_callable, load_ik

    if ik is None or isinstance(ik, UserIk):
        return ik
    if isinstance(ik, str):
        return load_ik(ik)
    return ik_from_callable(ik)


def _path(value: str | Path | None, name: str) -> Path | None:
    if value is None:
        return None
    if not isinstance(value, (str, Path)):
        raise ConfigError(f"{name} must be a path (str or Path), got a {type(value).__name__}")
    if str(value) == "":
        raise ConfigError(f"{name} is an empty path")
    return Path(value).absolute()  # now: user code may change the working folder later


def _integer(value: object, name: str) -> int:
    """``value`` as an ``int``: any whole number (``numpy.int64`` too), never a bool."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ConfigError(f"{name} must be a whole number, got {value!r}")
    return int(value)


def _whole(value: object, name: str, low: int) -> int:
    """``value`` as an ``int`` >= ``low`` (see :func:`_integer`)."""
    if (
        isinstance(value, (bool, np.bool_))
        or not isinstance(value, (int, np.integer))
        or int(value) < low
    ):
        raise ConfigError(f"{name} must be a whole number >= {low}, got {value!r}")
    return int(value)


def _stream(value: object, name: str) -> TextIO | None:
    """``value`` when it is None or a text stream (has ``write``)."""
    if value is not None and not callable(getattr(value, "write", None)):
        raise ConfigError(
            f"{name} must be a text stream with a write method (e.g. sys.stdout) or None, "
            f"got {value!r}"
        )
    return value  # type: ignore[return-value]


def _worker_ik(ik: object, in_process: bool) -> str | None:
    """The SPEC an evaluation's workers load the IK ``ik`` by (they rebuild it from a string).

    A callable is named ``module:function`` and must come back as the very same function when
    that SPEC is loaded: a module-level function of an importable module does; one of
    ``__main__`` does only when the episodes run in this process (one local worker).

    Raises:
        ConfigError: When the workers could not load it (a lambda, a closure, a method, a
            function of ``__main__`` with more than one worker or on Ray).
    """
    from kr210_sim.errors import IkSpecError
    from kr210_sim.sandbox.user_ik import UserIk, ik_from_callable, load_ik

    if ik is None or isinstance(ik, str):
        return ik
    user = ik if isinstance(ik, UserIk) else ik_from_callable(ik)  # type: ignore[arg-type]
    spec = user.spec
    try:
        same = load_ik(spec).function is user.function
    except IkSpecError:
        same = False
    if not same or (spec.startswith("__main__:") and not in_process):
        raise ConfigError(
            f"evaluate runs its episodes in worker processes that load the IK by a SPEC; "
            f"{spec} cannot be loaded there (a lambda, a closure, a method, or a function of "
            "the script itself with workers > 1): pass ik='path/to/file.py:function' or a "
            "function of an importable module"
        )
    return spec


class _LogLines:
    """A text stream that sends each complete line to the logger at INFO."""

    def __init__(self) -> None:
        self._buffer = ""

    def write(self, text: str) -> int:
        self._buffer += text
        *lines, self._buffer = self._buffer.split("\n")
        for line in lines:
            log.info("%s", line)
        return len(text)

    def flush(self) -> None:
        pass


# -- functions -------------------------------------------------------------------------------
def _perception(perceive: bool, spec: str | None, timeout: float | None) -> Any:
    """The sandbox of ``run(perception=SPEC)`` (started; None without a SPEC).

    Raises:
        ConfigError: A SPEC without ``perceive``, or a timeout without a SPEC.
        PerceptionSpecError: The SPEC names nothing loadable.
    """
    if spec is None:
        if timeout is not None:
            raise ConfigError("--perception-timeout needs --perception SPEC")
        return None
    if not isinstance(spec, str):
        raise ConfigError(f"perception must be a SPEC string, got a {type(spec).__name__}")
    if not perceive:
        raise ConfigError("--perception needs --perceive (it replaces our perception)")
    from kr210_sim.sandbox.perception_sandbox import DEFAULT_TIMEOUT, open_perception

    return open_perception(spec, DEFAULT_TIMEOUT if timeout is None else timeout)


def run(
    cycles: int = 10,
    seed: int = 0,
    slot: int = 0,
    randomize: bool = False,
    ik: str | Callable[..., Any] | UserIk | None = None,
    video: str | Path | VideoSettings | None = None,
    plots: str | Path | None = None,
    scene: str | Path | None = None,
    report: str | Path | None = None,
    out: TextIO | None = None,
    progress: TextIO | None = None,
    cell: str | Path | None = None,
    record: str | Path | None = None,
    record_rate: float = 30.0,
    render_workers: int | None = None,
    perceive: bool = False,
    perception: str | None = None,
    perception_timeout: float | None = None,
) -> RunReport:
    """Run and score pick-and-place cycles (``python -m kr210_sim run``).

    Args:
        cycles: Cycles to run (1-10000).
        seed: Seed of the run's generator (>= 0).
        slot: Slot 1-9, or 0 for a random slot per cycle.
        randomize: Randomise each cycle's target (pose, size, mass, friction).
        ik: Plan with this IK instead of ours: a SPEC string (``"my_ik.py:solve"``), or a
            callable ``solve(T, q_ref) -> q or None`` (see ``examples/ik_template.py``).
        video: Film the run: an MP4 path (default camera and size), or a
            :class:`~kr210_sim.media.video.VideoSettings` for cameras, size, fps and quality.
        plots: Folder for the PNG plots, or None.
        scene: Another MJCF cell, or None for the committed scene.
        report: Write the JSON report here (atomically), or None to only return it.
        out: Stream for the one-line-per-cycle output (None: logger ``kr210_sim.api``).
        progress: Stream for the video's progress bar (None: stderr).
        cell: A cell file (TOML) to compile and run instead of a scene (``--cell``).
        record: Write a recording of the run here (``.npz``; ``replay`` renders it).
        record_rate: Frames per simulated second of the recording [Hz].
        render_workers: Processes that render the video (default: one per core).
        perceive: Pick from what the cell's sensors see (the pipeline's estimate), not the
            simulator's pose; the truth only scores (each cycle's ``perception`` block).
        perception: With ``perceive``, your perception function in place of our pipeline: a
            SPEC (``"my_perception.py:perceive"``; the contract:
            :mod:`kr210_sim.sandbox.user_perception`), run in a jail.
        perception_timeout: Time the function may take per look [s] (default 10).

    Returns:
        The run's report; ``to_dict()`` is the JSON ``run --report`` writes.

    Raises:
        ConfigError: A bad argument or an output path that cannot be written (before any cycle
            runs).
        IkSpecError: ``ik`` names nothing loadable.
        PerceptionSpecError: ``perception`` names nothing loadable.
        SceneError: The scene cannot be loaded.
        VideoFailedError: The video could not be made (the cycles ran, the report was written;
            it is the exception's ``report``).
        RunInterrupted: Ctrl-C or SIGTERM stopped the cycles (the report of those finished
            was written; it is the exception's ``report``).
    """
    from kr210_sim.jobs import run_job
    from kr210_sim.media.video import VideoSettings
    from kr210_sim.sim.runner import RunConfig

    if not isinstance(randomize, bool):
        raise ConfigError(f"randomize must be True or False, got {randomize!r}")
    if not isinstance(perceive, bool):
        raise ConfigError(f"perceive must be True or False, got {perceive!r}")
    config = RunConfig(
        cycles=_integer(cycles, "cycles"),
        seed=_whole(seed, "seed", 0),
        slot=_integer(slot, "slot"),
        randomize=randomize,
        perceive=perceive,
    )
    out = _stream(out, "out")
    progress = _stream(progress, "progress")
    user_ik = as_user_ik(ik)
    sandbox = _perception(perceive, perception, perception_timeout)
    settings: VideoSettings | None
    if video is None or isinstance(video, VideoSettings):
        settings = video
    else:
        settings = VideoSettings(path=_path(video, "video"))  # type: ignore[arg-type]
    job = run_job(
        config,
        _path(report, "report"),
        video=settings,
        plots_dir=_path(plots, "plots"),
        out=out if out is not None else _LogLines(),  # type: ignore[arg-type]
        progress_stream=progress,
        scene=_path(scene, "scene"),
        ik=user_ik,
        cell=_path(cell, "cell"),
        record=_path(record, "record"),
        record_rate=record_rate,
        render_workers=render_workers,
        perception=sandbox,
    )
    result = RunReport(
        job.report,
        job.report_path,
        cycles=tuple(job.results),
        video_path=settings.path if settings is not None and job.video_error is None else None,
        video_frames=job.video_frames,
        video_error=job.video_error,
        plot_paths=tuple(job.plot_paths),
        record_path=_path(record, "record") if job.record_frames else None,
        record_frames=job.record_frames,
    )
    if job.interrupted is not None:
        raise RunInterrupted(getattr(job.interrupted, "signum", 2), result) from job.interrupted
    if job.video_error is not None:
        raise VideoFailedError(job.video_error, result)
    return result


def evaluate(
    episodes: int = 100,
    seed: int = 0,
    randomize: bool = False,
    workers: int = 1,
    scene: str | Path | None = None,
    report: str | Path | None = None,
    progress: TextIO | None = None,
    **options: Any,
) -> EvalReport:
    """Monte-Carlo evaluation over seeded episodes (``python -m kr210_sim evaluate``).

    A thin wrapper of :func:`kr210_sim.eval.evaluate.evaluate`: ``options`` go to its
    :class:`~kr210_sim.eval.evaluate.EvalConfig` (``backend``, ``address``, ...) as they are.

    Args:
        episodes: Episodes (>= 1).
        seed: Seed of the episode seeds.
        randomize: Randomise each episode's target.
        workers: Local worker processes (the results do not depend on it).
        scene: Another MJCF cell, or None for the committed scene.
        report: Write the JSON report here (atomically), or None to only return it.
        progress: Stream for the progress line (None: stderr).
        **options: Further :class:`EvalConfig` fields.

    Returns:
        The evaluation's report (``summary``: success rate, its 95 % interval, failures).

    Raises:
        ConfigError: A bad argument or an unwritable report path (before anything runs).
        SceneError: The scene cannot be loaded.
        RunInterrupted: Ctrl-C stopped it (the report of the episodes finished was written).
    """
    from kr210_sim.cell.load import load_model
    from kr210_sim.eval import evaluate as evaluation
    from kr210_sim.util.outputs import check_writable

    if "ik" in options:
        in_process = (
            _whole(workers, "workers", 1) == 1 and options.get("backend", "local") == "local"
        )
        options["ik"] = _worker_ik(options["ik"], in_process)
    if "cell" in options:
        options["cell"] = _path(options["cell"], "cell")
    progress = _stream(progress, "progress")
    try:
        config = evaluation.EvalConfig(
            episodes=_whole(episodes, "episodes", 1),
            seed=_whole(seed, "seed", 0),
            randomize=randomize,
            workers=_whole(workers, "workers", 1),
            scene=_path(scene, "scene"),
            **options,
        )
    except TypeError as exc:  # an option EvalConfig does not have
        raise ConfigError(f"evaluate: {exc}") from None
    report_path = _path(report, "report")
    if report_path is not None:
        check_writable(report_path)
    if config.cell is None:
        load_model(config.scene)  # a bad scene fails here, before any worker starts
    if config.perceive and config.perception is None:  # a cell's own recogniser: trained here,
        from kr210_sim.cell.load import model_for  # once, and the workers read it from the cache
        from kr210_sim.sensors.recognisers import recogniser_for

        recogniser_for(model_for(config.scene, config.cell))
    outcome = evaluation.evaluate(config, report=report_path, progress=progress)
    result = EvalReport(outcome.report, outcome.report_path)
    if outcome.signal is not None:
        raise RunInterrupted(outcome.signal, result)
    return result


def ik_check(
    ik: str | Callable[..., Any] | UserIk,
    cases: int = 1000,
    seed: int = 0,
    report: str | Path | None = None,
    plots: str | Path | None = None,
    progress: TextIO | None = None,
) -> IkCheckReport:
    """Grade an IK function on the cell's poses, singular and limit poses and random ones
    (``python -m kr210_sim ik-check``).

    Args:
        ik: A SPEC string or a callable ``solve(T, q_ref)`` (see :func:`as_user_ik`).
        cases: Random poses on top of the fixed set (>= 0).
        seed: Seed of the random poses (>= 0).
        report: Write the JSON report here, or None to only return it.
        plots: Folder for the PNG plots, or None.
        progress: Stream for the progress line on long checks (None: stderr).

    Returns:
        The check's report (``passed``, ``summary``, one record per case).

    Raises:
        IkSpecError: ``ik`` names nothing loadable.
        ConfigError: A bad argument or an unwritable output.
        RunInterrupted: Ctrl-C or a termination signal stopped the check; the report of the
            cases tried (``interrupted``: the signal's name) was written and is its ``report``.
    """
    from kr210_sim.grading.ikcheck import run_check

    if ik is None:
        raise ConfigError("ik_check needs an IK: a SPEC string or a callable solve(T, q_ref)")
    user_ik = as_user_ik(ik)
    assert user_ik is not None
    _whole(cases, "cases", 0)
    _whole(seed, "seed", 0)
    report_path = _path(report, "report")
    result = run_check(user_ik, cases, seed, report_path, _path(plots, "plots"), progress)
    out = IkCheckReport(result.report, report_path, result.text, result.plot_paths)
    if result.interrupted is not None:
        raise RunInterrupted(getattr(result.interrupted, "signum", signal.SIGINT), out)
    return out


def grade(
    submissions: str | Path | Sequence[str | Path],
    cases: int = 1000,
    cycles: int = 10,
    seed: int = 0,
    timeout: float = 120.0,
    ik_timeout: float = 2.0,
    memory_mb: int = 1024,
    workers: int | None = None,
    min_success: float = 0.8,
    report: str | Path | None = None,
    html: str | Path | None = None,
    out: TextIO | None = None,
    jail: bool = True,
) -> GradeReport:
    """Grade a class of IK solutions, each in its own sandbox (``python -m kr210_sim grade``).

    Args:
        submissions: A folder (each ``.py`` file or subfolder is a student), a ``.py`` file or
            a SPEC, or a list of them.
        cases: Random ik-check poses on top of the fixed set (0 to 1,000,000).
        cycles: Cycles of each student's run (1 to 10,000).
        seed: Seed of the poses and the runs (>= 0).
        timeout: The student's own time, in all [s]: importing its module and answering the
            calls (our checks and simulation do not count).
        ik_timeout: Time per IK call [s].
        memory_mb: Memory limit of each student's IK process [MB] (>= 256).
        workers: Students graded at once (default: one per core).
        min_success: The run's pass bar (share of ``cycles``).
        report: Write the JSON report here (atomically), or None to only return it.
        html: Write the self-contained leaderboard page here, or None.
        out: Stream for a line per student as each one finishes (None: logger
            ``kr210_sim.api``).
        jail: Each student's IK in a bubblewrap jail; False: unjailed, as ``--no-jail``.

    Returns:
        The leaderboard's report: ``verdicts``, ``students`` (records in leaderboard order),
        ``passed``.

    Raises:
        ConfigError: A bad argument, a submission that does not exist or names no student, or
            an output that cannot be written, or no jail (before any student is graded).
        RunInterrupted: Ctrl-C or SIGTERM stopped the grading (the report of the students
            finished was written; it is the exception's ``report``).
    """
    import os

    from kr210_sim.grading.grade import GradeSettings, find_students
    from kr210_sim.grading.grade import grade as grade_class

    if isinstance(submissions, str | Path):
        submissions = [submissions]
    settings = GradeSettings(
        cases=_whole(cases, "cases", 0),
        cycles=_whole(cycles, "cycles", 1),
        seed=_whole(seed, "seed", 0),
        timeout=timeout,
        ik_timeout=ik_timeout,
        memory_mb=_whole(memory_mb, "memory_mb", 1),
        workers=len(os.sched_getaffinity(0)) if workers is None else _whole(workers, "workers", 1),
        min_success=min_success,
        jail=bool(jail),
    )
    out = _stream(out, "out")
    students = find_students(submissions)
    report_path, html_path = _path(report, "report"), _path(html, "html")
    result = grade_class(
        students,
        settings,
        report_path,
        html_path,
        out=out if out is not None else _LogLines(),  # type: ignore[arg-type]
    )
    graded = GradeReport(result.report, report_path, text=result.text, html_path=result.html_path)
    if result.interrupted is not None:
        raise RunInterrupted(getattr(result.interrupted, "signum", 2), graded)
    return graded
