"""Failed episodes of an evaluation, re-run and recorded (``evaluate --record-failures DIR``).

Episodes are pure functions of their seed and IK (see :mod:`kr210_sim.eval.evaluate`), so a
re-run of a failed one is that episode: :func:`record_episode` runs it again with the state
recorder of :mod:`kr210_sim.media.recording` as a step hook and writes
``<out_dir>/<seed>_<reason>.npz``, which ``replay`` renders.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from kr210_sim.media.recording import (
    DEFAULT_RATE,
    DEFAULT_TAIL,
    StateRecorder,
    model_identity,
    run_meta,
    write_recording,
)

import mujoco  # isort: skip

if TYPE_CHECKING:
    from kr210_sim.eval.episode import Perceive
    from kr210_sim.sandbox.user_ik import UserIk


@dataclass(frozen=True, slots=True)
class EpisodeRecording:
    """Where :func:`record_episode` wrote a failed episode, and what it was.

    Attributes:
        path: The recording.
        reason: The failure reason (or "success").
        frames: Frames recorded.
    """

    path: Path
    reason: str
    frames: int


def record_episode(
    seed: int,
    randomize: bool,
    out_dir: Path | str,
    scene: Path | None = None,
    rate: float = DEFAULT_RATE,
    model: mujoco.MjModel | None = None,
    ik: UserIk | None = None,
    perceive: Perceive = False,
) -> EpisodeRecording:
    """Re-run one evaluation episode and write its recording to ``<out_dir>/<seed>_<reason>.npz``.

    Episodes are pure functions of their seed and IK (see :mod:`kr210_sim.eval.evaluate`): a fresh
    cell and one cycle of ``RunConfig(cycles=1, seed=seed, randomize=randomize)``, built by
    :func:`kr210_sim.sim.session.episode_runner` as the episode was, so the re-run is the
    episode. The closing bin shot is recorded too.

    Args:
        seed: The episode's seed.
        randomize: Whether the evaluation randomised its targets.
        out_dir: Folder for the recording (made when missing).
        scene: MJCF scene of the evaluation (default: the committed scene).
        rate: Frames per simulated second [Hz].
        model: A pristine copy of the scene's model, to skip loading it again (it is copied).
        ik: The user's IK the evaluation planned with (:func:`kr210_sim.sandbox.user_ik.load_ik`),
            or None for ours.
        perceive: Whether the evaluation picked from what the sensors saw (``--perceive``).

    Returns:
        Where the recording went and the episode's reason (``success`` if it did not fail).

    Raises:
        ConfigError: When the folder or file cannot be written.
    """
    from kr210_sim.cell.load import model_at
    from kr210_sim.score.report import build_report
    from kr210_sim.sim.session import episode_runner
    from kr210_sim.util.outputs import check_folder

    folder = check_folder(out_dir)
    pristine = model if model is not None else model_at(scene)
    identity = model_identity(pristine)
    from kr210_sim.eval.episode import perceiver_factory

    factory = perceiver_factory(perceive) if perceive else None
    runner = episode_runner(seed, randomize=randomize, model=pristine, ik=ik, perceiver=factory)
    config = runner.config
    recorder = StateRecorder(
        runner.model, runner.cell.handles.target_geoms, runner.status, rate=rate
    )
    runner.cell.hooks.append(recorder)
    result = runner.run_cycle(1, runner.slot_for_cycle())
    recorder.tail = True
    runner.idle(DEFAULT_TAIL)
    runner.cell.hooks.remove(recorder)
    reason = result.reason or "success"
    report = build_report(config, runner.results, 0.0, events=runner.events)
    meta = run_meta(config, identity, scene, report)
    path = folder / f"{seed}_{reason}.npz"
    write_recording(path, recorder.recording(meta))
    return EpisodeRecording(path, reason, recorder.frames)


def record_failures(
    records: Iterable[Mapping[str, Any]],
    randomize: bool,
    out_dir: Path | str,
    scene: Path | None = None,
    rate: float = DEFAULT_RATE,
    ik: str | None = None,
    ik_timeout: float | None = None,
    perceive: Perceive = False,
) -> list[EpisodeRecording]:
    """Record every failed episode of an evaluation (``evaluate --record-failures DIR``).

    Args:
        records: The evaluation report's episode records (each has ``seed`` and ``success``).
        randomize: Whether the evaluation randomised its targets.
        out_dir: Folder for the recordings, named ``<seed>_<reason>.npz``.
        scene: MJCF scene of the evaluation (default: the committed scene).
        rate: Frames per simulated second [Hz].
        ik: SPEC of the user's IK the evaluation planned with (``--ik``), or None for ours.
        ik_timeout: Its time limit per call (``--ik-timeout``) [s], or None.
        perceive: Whether the evaluation picked from what the sensors saw (``--perceive``).

    Returns:
        One entry per failed episode, in the records' order.
    """
    from kr210_sim.cell.load import model_at
    from kr210_sim.util.outputs import check_folder

    failed = [r for r in records if not r["success"]]
    if not failed:
        return []
    check_folder(out_dir)
    pristine = model_at(scene)
    user_ik = None
    if ik is not None:
        from kr210_sim.sandbox.guarded import load_user_ik

        user_ik = load_user_ik(ik, ik_timeout)
    return [
        record_episode(int(r["seed"]), randomize, out_dir, scene, rate, pristine, user_ik, perceive)
        for r in failed
    ]
