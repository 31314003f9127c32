"""Monte-Carlo evaluation: many independent seeded pick-and-place episodes, locally or on Ray.

Each episode is a pure function of its seed (see :mod:`kr210_sim.eval.episode`), so the report does
not depend on the backend, the worker count, the order episodes finish in, or on whether the
evaluation was interrupted and resumed: only the fields under ``wall_execution`` (backend, workers,
nodes, wall time) do. Records stream to the episodes file beside the report as they finish
(:mod:`kr210_sim.eval.stream`), the summary is accumulated in bounded memory
(:mod:`kr210_sim.eval.summary`), and the report keeps the summary plus the failed episodes'
records.

SIGINT and SIGTERM on the driver stop the evaluation: the workers are stopped, the report of the
episodes finished so far is written, and the outcome names the signal (exit 130 or 143).
"""

from __future__ import annotations

import logging
import os
import signal
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from pathlib import Path
from types import FrameType
from typing import Any, TextIO

from kr210_sim.errors import ConfigError
from kr210_sim.eval.episode import episode_seed, run_episode
from kr210_sim.eval.local_backend import EpisodeError, LocalBackend
from kr210_sim.eval.ray_backend import RayBackend
from kr210_sim.eval.stream import EpisodeWriter, episodes_path, read_records
from kr210_sim.eval.summary import EpisodeSummary, wilson_interval
from kr210_sim.util.interrupts import Interrupted
from kr210_sim.util.progress import ProgressLine, bar

__all__ = [
    "BACKENDS",
    "EpisodeError",
    "EvalConfig",
    "EvalOutcome",
    "Terminated",
    "episode_seed",
    "evaluate",
    "run_episode",
    "wilson_interval",
]

log = logging.getLogger(__name__)

BACKENDS = ("local", "ray")


class Terminated(Interrupted):
    """SIGTERM arrived: unwinds exactly like Ctrl-C (:class:`kr210_sim.util.interrupts.Interrupted`
    with SIGTERM's number, so ``interrupts.exit_code`` gives 143 for it as for ``run``).

    A KeyboardInterrupt on purpose: libraries that wait in native code (Ray's ``wait``) turn a
    pending KeyboardInterrupt into their own, and anything else into a SystemError. Which
    signal it was is recorded by the handler, not read from the exception's class.
    """

    def __init__(self) -> None:
        super().__init__(signal.SIGTERM)


#: Most episodes in one evaluation: its done-list takes a byte per episode (100 MB here).
MAX_EPISODES = 100_000_000


@dataclass(frozen=True, slots=True)
class EvalConfig:
    """Settings of an evaluation.

    Attributes:
        episodes: Number of episodes.
        seed: Seed from which the episode seeds are derived.
        randomize: Randomise each episode's target.
        workers: Worker processes (local; None: 1) or tasks in flight (ray; None: the cluster's
            CPUs). Capped at the episodes to run; never changes the results.
        scene: MJCF scene path, or None for the committed scene.
        backend: ``local`` (processes on this machine) or ``ray``.
        address: Ray cluster address (``auto`` or ``host:port``); None starts Ray here.
        ik: SPEC of the user's IK to plan every episode with (``--ik``), or None for ours.
        cell: Cell file (TOML) compiled instead of a scene (``--cell``), or None.
        ik_timeout: Time limit per call of the user's IK (``--ik-timeout``) [s]: it then runs
            in a process of its own per worker, and a call with no answer in time makes that
            episode ``ik_failed``. None: no limit, imported into each worker.
        perceive: Pick every episode from what the cell's sensors see (``--perceive``): the
            records get ``perception`` and the summary its block.
        perception: With ``perceive``, the SPEC of a user's perception function in place of our
            pipeline (``--perception``): in a jail per worker process.
        perception_timeout: Time that function may take per look [s] (None: 10 s).
    """

    episodes: int = 100
    seed: int = 0
    randomize: bool = False
    workers: int | None = None
    scene: Path | None = None
    backend: str = "local"
    address: str | None = None
    ik: str | None = None
    cell: Path | None = None
    ik_timeout: float | None = None
    perceive: bool = False
    perception: str | None = None
    perception_timeout: float | None = None

    def __post_init__(self) -> None:
        if self.scene is not None and self.cell is not None:
            raise ConfigError("give --scene or --cell, not both (a cell compiles to a scene)")
        if (
            not isinstance(self.episodes, int)
            or isinstance(self.episodes, bool)
            or not 1 <= self.episodes <= MAX_EPISODES
        ):
            raise ConfigError(
                f"episodes must be a whole number from 1 to {MAX_EPISODES:,}, got {self.episodes!r}"
            )
        if self.workers is not None and (not isinstance(self.workers, int) or self.workers < 1):
            raise ConfigError(f"workers must be a whole number >= 1, got {self.workers!r}")
        if not isinstance(self.seed, int) or isinstance(self.seed, bool) or self.seed < 0:
            raise ConfigError(f"seed must be a whole number >= 0, got {self.seed!r}")
        if self.ik is not None and not isinstance(self.ik, str):
            raise ConfigError(
                f"ik must be a SPEC string (path/to/file.py:function), got {self.ik!r}"
            )
        if self.backend not in BACKENDS:
            raise ConfigError(f"backend must be one of {', '.join(BACKENDS)}, got {self.backend!r}")
        if self.ik_timeout is not None and (self.ik is None or not self.ik_timeout > 0):
            raise ConfigError("--ik-timeout needs --ik SPEC and a time > 0 s")
        if self.address is not None and self.backend != "ray":
            raise ConfigError("--address needs --backend ray")
        if self.perception_timeout is not None and (
            self.perception is None or not self.perception_timeout > 0
        ):
            raise ConfigError("--perception-timeout needs --perception SPEC and a time > 0 s")
        if self.perception is not None and not self.perceive:
            raise ConfigError("--perception needs --perceive (it replaces our perception)")

    @property
    def perceiving(self) -> bool | tuple[str, float]:
        """How episodes perceive (:data:`kr210_sim.eval.episode.Perceive`)."""
        if self.perception is None:
            return self.perceive
        from kr210_sim.sandbox.perception_sandbox import DEFAULT_TIMEOUT

        timeout = self.perception_timeout
        return (self.perception, DEFAULT_TIMEOUT if timeout is None else timeout)


@dataclass(frozen=True, slots=True)
class EvalOutcome:
    """What an evaluation produced.

    Attributes:
        report: The JSON-ready report.
        signal: The signal that cut the evaluation short (SIGINT or SIGTERM), or None.
        report_path: Where the report was written, or None.
        episodes_path: Where the records were streamed, or None.
    """

    report: dict[str, Any]
    signal: int | None = None
    report_path: Path | None = None
    episodes_path: Path | None = None

    @property
    def interrupted(self) -> bool:
        """Whether a signal cut the evaluation short."""
        return self.signal is not None


# -- signals -----------------------------------------------------------------------------------
class _Signals:
    """The driver's signals during an evaluation (main thread only).

    While armed, SIGINT raises KeyboardInterrupt and SIGTERM :class:`Terminated` (and is
    remembered), except inside :meth:`held` blocks, which they interrupt only at their end;
    once the evaluation winds down (stopping the workers, writing the report), both are ignored.
    """

    def __init__(self) -> None:
        self.active = threading.current_thread() is threading.main_thread()
        self.terminated = False
        self._held = False
        self._pending: int | None = None
        self._saved: dict[int, Any] = {}

    def _on_signal(self, signum: int, frame: FrameType | None) -> None:
        if signum == signal.SIGTERM:
            self.terminated = True
        if self._held:
            self._pending = signum
            return
        _raise_for(signum)

    def arm(self) -> None:
        """(Re)install the handlers (Ray's ``init`` installs its own for SIGTERM)."""
        if self.active:
            for sig in (signal.SIGINT, signal.SIGTERM):
                self._save_and_set(sig, self._on_signal)

    @contextmanager
    def held(self) -> Iterator[None]:
        """A block that a signal does not cut in two (records are written and counted, or not)."""
        self._held = True
        try:
            yield
        finally:
            self._held = False
        if self._pending is not None:
            signum, self._pending = self._pending, None
            _raise_for(signum)

    def ignore(self) -> None:
        """Ignore SIGINT and SIGTERM from now on (until :meth:`restore`)."""
        if self.active:
            for sig in (signal.SIGINT, signal.SIGTERM):
                self._save_and_set(sig, signal.SIG_IGN)

    def _save_and_set(self, sig: int, handler: Any) -> None:
        previous = signal.signal(sig, handler)
        self._saved.setdefault(sig, previous)

    def restore(self) -> None:
        """Put back the handlers found on arming."""
        for sig, handler in self._saved.items():
            signal.signal(sig, handler)
        self._saved.clear()


def _raise_for(signum: int) -> None:
    raise Terminated if signum == signal.SIGTERM else KeyboardInterrupt


@contextmanager
def _signals() -> Iterator[_Signals]:
    guard = _Signals()
    guard.arm()
    try:
        yield guard
    finally:
        guard.restore()


# -- the evaluation ----------------------------------------------------------------------------
class _Bar:
    """The evaluation's progress line: episodes done, failures, elapsed and estimated time."""

    def __init__(self, total: int, already: int, stream: TextIO) -> None:
        self.total = total
        self.already = already  # resumed: not part of this run's rate
        self.line = ProgressLine(stream, log_interval=10.0)
        self.line.last = self.line.start  # the first line after an interval, not at once
        self.shown = False

    def update(self, done: int, failed: int) -> None:
        if done < self.total and not self.line.due():
            return
        elapsed = self.line.elapsed
        ran = done - self.already
        eta = elapsed * (self.total - done) / ran if ran else 0.0
        self.line.show(
            f"evaluate {bar(done / self.total)} {done}/{self.total} episodes  "
            f"{failed} failed  elapsed {elapsed:4.0f} s  eta {eta:4.0f} s"
        )
        self.shown = True
        if done == self.total:
            self.close()

    def close(self) -> None:
        """End the line (on a terminal the next output starts on a new line)."""
        if self.shown:
            self.line.end()
            self.shown = False


def _identity(config: EvalConfig) -> dict[str, Any]:
    """What the episode records depend on (the episodes file's header): the seed, the
    randomisation, the compiled model's identity (not the path of the scene or cell file: the
    same file by another path is the same cell, an edited one is another), the IK's function
    and file content, and the library versions."""
    from kr210_sim.cell.load import model_for, model_identity
    from kr210_sim.sandbox.user_ik import ik_identity
    from kr210_sim.util.versions import versions

    ik: dict[str, Any] = {}
    if config.ik is not None:
        ik = {"ik": ik_identity(config.ik)}
    return {
        "seed": config.seed,
        "randomize": config.randomize,
        "model_sha256": model_identity(model_for(config.scene, config.cell)),
        **ik,
        **({"ik_timeout_s": config.ik_timeout} if config.ik_timeout is not None else {}),
        **({"perceive": True} if config.perceive else {}),
        **({"perception": ik_identity(config.perception)} if config.perception else {}),
        "versions": versions(),
    }


def _perception_config(config: EvalConfig) -> dict[str, Any]:
    """The report's ``perception`` and ``perception_timeout_s`` (``--perception``; none without
    it)."""
    perceiving = config.perceiving
    if not isinstance(perceiving, tuple):
        return {}
    return {"perception": perceiving[0], "perception_timeout_s": perceiving[1]}


def _check_outputs(config: EvalConfig, report: Path) -> None:
    """Refuse, before anything runs, a report or episodes file that cannot be written or that
    would overwrite an input (the scene, the cell file, the IK file, kr210_sim's own files).

    Raises:
        ConfigError: Naming the clash.
    """
    from kr210_sim.sandbox.user_ik import spec_file
    from kr210_sim.util.outputs import check_distinct, check_writable, is_stream
    from kr210_sim.util.paths import SCENE_PATH, URDF_PATH

    check_writable(report)
    outputs: dict[str, Path | None] = {"--report": report}
    if not is_stream(report):
        outputs["its episodes file"] = check_writable(episodes_path(report))
    check_distinct(
        outputs,
        {
            "--scene": config.scene if config.scene is not None else SCENE_PATH,
            "--cell": config.cell,
            "--ik": spec_file(config.ik) if config.ik is not None else None,
            "the URDF": URDF_PATH,
        },
    )


def _source(config: EvalConfig) -> Path | None:
    """What the workers load: the cell file (``.toml``, compiled) or the scene (MJCF)."""
    return config.cell if config.cell is not None else config.scene


def _local_workers(config: EvalConfig, todo: int) -> int:
    """Local worker processes: as asked, capped at the episodes to run; warn above the cores."""
    asked = config.workers or 1
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    if cores and asked > cores:
        log.warning("--workers %d is more than the %d cores of this machine", asked, cores)
    return max(1, min(asked, todo))


def evaluate(
    config: EvalConfig,
    report: Path | None = None,
    resume: bool = False,
    progress: TextIO | None = None,
) -> EvalOutcome:
    """Run an evaluation and build its report.

    Args:
        config: The evaluation's settings.
        report: Where to write the report (atomically); the records stream to the episodes
            file beside it. None: keep everything in memory, write nothing.
        resume: Continue from the episodes file beside ``report``, skipping the episodes in it.
        progress: Stream for the progress line (None: stderr).

    Returns:
        The outcome: the report (of the episodes finished so far when a signal cut it short)
        and the signal, if any.

    Raises:
        ConfigError: Bad settings, an episodes file of another evaluation, Ray missing.
        EpisodeError: An episode raised (a bug) or a worker died.
    """
    from kr210_sim.util.outputs import check_writable

    n = config.episodes
    if report is not None:
        _check_outputs(config, report)
    identity = _identity(config)
    summary = EpisodeSummary()
    done = bytearray(n)  # 1 where the episode's record is counted: results are keyed by episode
    from kr210_sim.util.outputs import is_stream

    # The episodes file lives beside the report; a report sent to a device or a pipe
    # (/dev/null, /dev/stdout) has no folder of its own to put it in: no episodes file then.
    streamed = report is not None and is_stream(check_writable(report))
    log_path = episodes_path(report) if report is not None and not streamed else None
    resuming = resume and log_path is not None and log_path.is_file()
    if resuming:
        assert log_path is not None
        _read_back(log_path, identity, summary, done)
    resumed = summary.episodes
    todo = n - resumed
    jobs = ((i, episode_seed(config.seed, i)) for i in range(n) if not done[i])
    backend: LocalBackend | RayBackend
    if config.backend == "ray":
        backend = RayBackend(
            config.workers,
            config.randomize,
            _source(config),
            config.address,
            todo,
            config.ik,
            config.ik_timeout,
            config.perceiving,
        )
    else:
        backend = LocalBackend(
            _local_workers(config, todo),
            config.randomize,
            _source(config),
            config.ik,
            config.ik_timeout,
            config.perceiving,
        )

    caught: int | None = None
    wall0 = time.perf_counter()
    progress_bar = _Bar(n, resumed, progress or sys.stderr)
    writer: EpisodeWriter | None = None
    with _signals() as guard:
        try:
            if todo:
                backend.start()
                guard.arm()  # again: Ray's init replaces the SIGTERM handler
                if log_path is not None:
                    writer = EpisodeWriter(log_path, identity, append=resuming)
                for records in backend.results(jobs):
                    with guard.held():  # the episodes file and the summary stay in step
                        fresh = [r for r in records if not done[r["episode"]]]  # never twice
                        if writer is not None:
                            writer.write(fresh)
                        for r in fresh:
                            done[r["episode"]] = 1
                            summary.add(r)
                        progress_bar.update(summary.episodes, summary.failed)
        except KeyboardInterrupt:  # Ctrl-C, or SIGTERM (Terminated, or re-raised by Ray)
            caught = signal.SIGTERM if guard.terminated else signal.SIGINT
        finally:
            guard.ignore()  # winding down: stopping the workers, writing the report
            progress_bar.close()
            backend.close()
            if writer is not None:
                writer.close()
        wall = time.perf_counter() - wall0
        execution = {**backend.execution(), "wall_time_s": wall, "resumed_episodes": resumed}
        payload = _report(config, summary, caught is not None, execution, identity, log_path)
        if report is not None:
            from kr210_sim.util.outputs import write_json_atomic

            write_json_atomic(report, payload)
    return EvalOutcome(payload, caught, report, log_path)


def _read_back(
    path: Path, identity: dict[str, Any], summary: EpisodeSummary, done: bytearray
) -> None:
    """Count the records of an episodes file into ``summary`` and ``done`` (resume).

    Raises:
        ConfigError: A record whose seed is not its episode's (edited by hand).
    """
    for record in read_records(path, identity):
        i = record["episode"]
        if record["seed"] != episode_seed(identity["seed"], i):
            raise ConfigError(
                f"cannot resume from {path}: episode {i} has seed {record['seed']}, not this "
                "evaluation's; run without --resume to start afresh"
            )
        if i < len(done) and not done[i]:  # a longer earlier evaluation: ignore the rest
            done[i] = 1
            try:
                summary.add(record)
            except (KeyError, TypeError, ValueError) as exc:
                raise ConfigError(
                    f"cannot resume from {path}: the record of episode {i} is damaged "
                    f"({type(exc).__name__}: {exc}); run without --resume to start afresh"
                ) from None
    log.info("resuming: %d of %d episodes already done", summary.episodes, len(done))


def _report(
    config: EvalConfig,
    summary: EpisodeSummary,
    interrupted: bool,
    execution: dict[str, Any],
    identity: dict[str, Any],
    log_path: Path | None,
) -> dict[str, Any]:
    """The JSON-ready report: config, summary, failed episodes' records, execution, versions."""
    return {
        "kind": "kr210_sim.evaluate",
        "config": {
            "episodes": config.episodes,
            "seed": config.seed,
            "randomize": config.randomize,
            "scene": str(config.scene) if config.scene else None,
            "model_sha256": identity["model_sha256"],
            "cell": str(config.cell) if config.cell else None,
            **({"ik": config.ik} if config.ik is not None else {}),
            **({"ik_timeout_s": config.ik_timeout} if config.ik_timeout is not None else {}),
            **({"perceive": True} if config.perceive else {}),
            **_perception_config(config),
            "randomization": _randomization(config),
            "replay": "python -m kr210_sim run --cycles 1 --seed <episode seed>"
            + (" --randomize" if config.randomize else "")
            + (" --perceive" if config.perceive else "")
            + (f" --perception {config.perception}" if config.perception else "")
            + (
                f" --perception-timeout {config.perception_timeout:g}"
                if config.perception_timeout is not None
                else ""
            )
            + (f" --ik {config.ik}" if config.ik is not None else "")
            + (f" --ik-timeout {config.ik_timeout:g}" if config.ik_timeout is not None else "")
            + (f" --scene {config.scene}" if config.scene else "")
            + (f" --cell {config.cell}" if config.cell else ""),
        },
        "summary": summary.summary(),
        "failed_episodes": summary.failed_records(),
        "episodes_file": log_path.name if log_path is not None else None,
        "interrupted": interrupted,
        "wall_execution": execution,
        "versions": identity["versions"],
    }


def _randomization(config: EvalConfig) -> dict[str, Any]:
    """The randomisation ranges of the evaluated cell (as its model holds them)."""
    from kr210_sim.cell.layout import CellLayout
    from kr210_sim.cell.load import model_for

    r = CellLayout.from_model(model_for(config.scene, config.cell)).randomization
    return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(r).items()}
