"""Monte-Carlo evaluation: many independent seeded pick-and-place episodes across processes.

Each episode is a pure function of ``(episode seed, randomize, scene)``: a fresh cell (a copy of
the pristine model, the arm at the ready pose, empty bin), one cycle from
``RunConfig(cycles=1, seed=episode_seed, randomize=...)``. Episode ``i``'s seed is drawn from
``numpy.random.SeedSequence([seed, i])``, so results do not depend on how episodes are spread
over workers (or, later, over a cluster), and any episode is replayed exactly by
``python -m kr210_sim run --cycles 1 --seed <episode seed> [--randomize]``.
"""

from __future__ import annotations

import copy
import math
import multiprocessing as mp
import signal
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from kr210_sim.errors import ConfigError
from kr210_sim.progress import ProgressLine, bar
from kr210_sim.runner import CycleResult, RunConfig, Runner

import mujoco  # isort: skip

#: Example seeds kept per failure reason.
EXAMPLES_PER_REASON = 5


@dataclass(frozen=True, slots=True)
class EvalConfig:
    """Settings of an evaluation.

    Attributes:
        episodes: Number of episodes.
        seed: Seed from which the episode seeds are derived.
        randomize: Randomise each episode's target.
        workers: Local worker processes (does not change the results).
        scene: MJCF scene path, or None for the committed scene.
        cell: Cell file (TOML) compiled instead of a scene, or None.
    """

    episodes: int = 100
    seed: int = 0
    randomize: bool = False
    workers: int = 1
    scene: Path | None = None
    cell: Path | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.episodes, int) or self.episodes < 1:
            raise ConfigError(f"episodes must be a whole number >= 1, got {self.episodes!r}")
        if not isinstance(self.workers, int) or self.workers < 1:
            raise ConfigError(f"workers must be a whole number >= 1, got {self.workers!r}")
        if self.seed < 0:
            raise ConfigError(f"seed must be >= 0, got {self.seed!r}")


def episode_seed(seed: int, index: int) -> int:
    """The seed of episode ``index`` (0-based) of an evaluation seeded with ``seed``."""
    return int(np.random.SeedSequence([seed, index]).generate_state(1, np.uint32)[0])


# -- one episode ----------------------------------------------------------------------------
_PRISTINE: mujoco.MjModel | None = None


def _init_worker(scene: Path | None, in_child: bool = False, cell: Path | None = None) -> None:
    """Load the scene once per process; every episode gets its own copy of it.

    Worker processes ignore Ctrl-C: the parent handles it (stops the pool, writes the report).
    """
    global _PRISTINE
    from kr210_sim.cells import model_for

    if in_child:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    _PRISTINE = model_for(scene, cell)


def run_episode(seed: int, randomize: bool) -> CycleResult:
    """One episode on a fresh copy of the worker's model (see the module docstring)."""
    assert _PRISTINE is not None, "call _init_worker first"
    config = RunConfig(cycles=1, seed=seed, randomize=randomize)
    runner = Runner(config, model=copy.copy(_PRISTINE))
    return runner.run_cycle(1, runner.slot_for_cycle())


def _episode_task(job: tuple[int, int, bool]) -> tuple[int, dict[str, Any]]:
    index, seed, randomize = job
    return index, episode_record(index, seed, run_episode(seed, randomize))


def episode_record(index: int, seed: int, r: CycleResult) -> dict[str, Any]:
    """The report's record of one episode."""
    s = r.target.spec
    return {
        "episode": index,
        "seed": seed,
        "slot": r.slot,
        "success": r.success,
        "reason": r.reason,
        "detail": r.detail,
        "cycle_time": r.cycle_time,
        "creep_mm": r.creep_mm,
        "max_tracking_error_deg": max(r.max_tracking_error_deg),
        "max_gripper_tracking_error_mm": r.max_gripper_tracking_error_mm,
        "grasp_attempts": r.grasp_attempts,
        "target": {
            "position": [round(x, 6) for x in r.target.position],
            "yaw": round(r.target.yaw, 6),
            "radius": round(s.radius, 6),
            "length": round(s.length, 6),
            "mass": round(s.mass, 6),
            "friction": round(s.friction, 6),
        },
        "wall_time": r.wall_time,
    }


# -- many episodes ---------------------------------------------------------------------------
def _episodes(config: EvalConfig) -> Iterator[tuple[int, dict[str, Any]]]:
    """Run the episodes, yielding ``(index, record)`` as they finish (any order)."""
    jobs = [(i, episode_seed(config.seed, i), config.randomize) for i in range(config.episodes)]
    if config.workers == 1:
        _init_worker(config.scene, cell=config.cell)
        for job in jobs:
            yield _episode_task(job)
        return
    # spawn: no state (threads, GL contexts) is inherited from this process.
    ctx = mp.get_context("spawn")
    chunk = max(1, min(8, config.episodes // (8 * config.workers)))
    with ctx.Pool(
        config.workers, initializer=_init_worker, initargs=(config.scene, True, config.cell)
    ) as pool:
        try:
            yield from pool.imap_unordered(_episode_task, jobs, chunksize=chunk)
        except BaseException:
            pool.terminate()
            raise


def wilson_interval(successes: int, n: int, z: float = 1.959964) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion (95 % for the default ``z``)."""
    if n == 0:
        return 0.0, 1.0
    p = successes / n
    denom = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    return max(0.0, centre - half), min(1.0, centre + half)


def summarise_episodes(records: list[dict[str, Any]]) -> dict[str, Any]:
    """Success rate with its 95 % Wilson interval, failures with examples, cycle-time stats."""
    n = len(records)
    ok = sum(r["success"] for r in records)
    lo, hi = wilson_interval(ok, n)
    failures: dict[str, dict[str, Any]] = {}
    for r in records:
        if r["success"]:
            continue
        f = failures.setdefault(r["reason"], {"count": 0, "examples": []})
        f["count"] += 1
        if len(f["examples"]) < EXAMPLES_PER_REASON:
            f["examples"].append({"seed": r["seed"], "slot": r["slot"], "detail": r["detail"]})
    times = np.array([r["cycle_time"] for r in records if r["success"]])
    creep = [r["creep_mm"] for r in records if r["reason"] not in ("unreachable", "grasp_missed")]

    def stat(fn: Callable[[np.ndarray], Any]) -> float:
        return round(float(fn(times)), 6) if len(times) else 0.0

    return {
        "episodes": n,
        "successes": ok,
        "success_rate": ok / n if n else 0.0,
        "success_rate_ci95": [round(lo, 6), round(hi, 6)],
        "failures": dict(sorted(failures.items())),
        "grasp_retries": sum(r["grasp_attempts"] - 1 for r in records),
        "retries_recovered": sum(r["grasp_attempts"] > 1 and r["success"] for r in records),
        "cycle_time": {
            "mean": stat(np.mean),
            "std": stat(np.std),
            "p50": stat(np.median),
            "p95": stat(lambda t: np.percentile(t, 95)),
            "max": stat(np.max),
        },
        "max_creep_mm": max(creep, default=0.0),
        "max_tracking_error_deg": max((r["max_tracking_error_deg"] for r in records), default=0.0),
    }


class _Bar:
    """The evaluation's progress line: episodes done, failures, elapsed and estimated time."""

    def __init__(self, total: int, stream: TextIO) -> None:
        self.total = total
        self.line = ProgressLine(stream, log_interval=10.0)
        self.line.last = self.line.start  # the first line after an interval, not at once

    def update(self, done: int, failed: int) -> None:
        if done < self.total and not self.line.due():
            return
        elapsed = self.line.elapsed
        eta = elapsed * (self.total - done) / done if done else 0.0
        self.line.show(
            f"evaluate {bar(done / self.total)} {done}/{self.total} episodes  "
            f"{failed} failed  elapsed {elapsed:4.0f} s  eta {eta:4.0f} s"
        )
        if done == self.total:
            self.line.end()


def evaluate(config: EvalConfig, progress: TextIO | None = None) -> tuple[dict[str, Any], bool]:
    """Run an evaluation and build its report.

    Args:
        config: The evaluation's settings.
        progress: Stream for the progress bar (None: stderr).

    Returns:
        The JSON-ready report and whether Ctrl-C cut the evaluation short (the report then holds
        the episodes finished so far).
    """
    from kr210_sim.report import versions

    bar = _Bar(config.episodes, progress or sys.stderr)
    records: list[dict[str, Any]] = []
    failed = 0
    wall0 = time.perf_counter()
    interrupted = False
    try:
        for _, record in _episodes(config):
            records.append(record)
            failed += not record["success"]
            bar.update(len(records), failed)
    except KeyboardInterrupt:
        interrupted = True
    wall = time.perf_counter() - wall0
    records.sort(key=lambda r: r["episode"])
    report = {
        "kind": "kr210_sim.evaluate",
        "config": {
            "episodes": config.episodes,
            "seed": config.seed,
            "randomize": config.randomize,
            "scene": str(config.scene) if config.scene else None,
            "cell": str(config.cell) if config.cell else None,
            "randomization": _randomization(config),
            "replay": "python -m kr210_sim run --cycles 1 --seed <episode seed>"
            + (" --randomize" if config.randomize else "")
            + (f" --cell {config.cell}" if config.cell else "")
            + (f" --scene {config.scene}" if config.scene else ""),
        },
        "summary": summarise_episodes(records),
        "episodes": records,
        "interrupted": interrupted,
        "execution": {"workers": config.workers, "wall_time_s": wall},
        "versions": versions(),
    }
    return report, interrupted


def _randomization(config: EvalConfig) -> dict[str, Any]:
    """The randomisation ranges of the evaluated cell (as its model holds them)."""
    from dataclasses import asdict

    from kr210_sim.cells import model_for
    from kr210_sim.layout import CellLayout

    r = CellLayout.from_model(model_for(config.scene, config.cell)).randomization
    return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(r).items()}
