"""One evaluation episode: a pure function of its seed, run in whichever process holds the model.

Each episode is a fresh cell (a copy of the pristine model, the arm at the ready pose, an empty
bin) running one cycle of ``RunConfig(cycles=1, seed=episode_seed, randomize=...)``
(:func:`kr210_sim.sim.session.episode_runner`). Episode
``i``'s seed is drawn from ``numpy.random.SeedSequence([seed, i])``, so results do not depend on
how episodes are spread over processes or machines, and any episode is replayed exactly by
``python -m kr210_sim run --cycles 1 --seed <episode seed> [--randomize] [--perceive]``.
With ``perceive`` the episode picks from what the cell's sensors saw
(:class:`kr210_sim.sensors.perceiver.Perceiver`; the cell's recogniser is loaded once per
process, the sensors' renderers are freed after each episode).

Every process that runs episodes (the driver, a local worker, a Ray worker) loads the scene once
and keeps it: :func:`run_chunk` is the unit of work that the backends ship.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from kr210_sim.score.result import CycleResult, cycle_record
from kr210_sim.sim.session import episode_runner

if TYPE_CHECKING:  # the sensors render: imported only for perceived episodes
    from kr210_sim.plan.planner import Planner
    from kr210_sim.sensors.perceiver import Perceiver
    from kr210_sim.sim.perceived import PerceiverFactory

import mujoco  # isort: skip

#: The scene loaded in this process: (path as given, model). One at a time.
_PRISTINE: tuple[str | None, mujoco.MjModel] | None = None


def episode_seed(seed: int, index: int) -> int:
    """The seed of episode ``index`` (0-based) of an evaluation seeded with ``seed``: 128 bits
    of NumPy's ``SeedSequence([seed, index])``.

    Distinct ``(seed, index)`` pairs give distinct seeds but for a chance of about
    ``n**2 / 2**129`` in ``n`` episodes (none in any feasible sweep; the 32-bit seeds used
    before repeated 12 times in 300,000 episodes).
    """
    words = np.random.SeedSequence([seed, index]).generate_state(4, np.uint32)
    return sum(int(w) << (32 * k) for k, w in enumerate(words))


def load_pristine(scene: Path | str | None) -> mujoco.MjModel:
    """The pristine model of ``scene`` (an MJCF file, a ``.toml`` cell file compiled, or None
    for the committed scene), loaded once per process."""
    global _PRISTINE
    key = str(scene) if scene is not None else None
    if _PRISTINE is None or _PRISTINE[0] != key:
        from kr210_sim.cell.load import model_at

        _PRISTINE = (key, model_at(scene))
    return _PRISTINE[1]


#: How an episode perceives: False (the truth is told), True (our pipeline), or ``(SPEC,
#: timeout [s])``: a user's perception function (``--perception``), in a jail per process.
Perceive = bool | tuple[str, float]


def perceiver_factory(perceive: Perceive = True) -> PerceiverFactory:
    """What makes the perceivers of this process's ``--perceive`` episodes (with ``(SPEC,
    timeout)``: the user's function's, its sandbox started once per process)."""
    if isinstance(perceive, tuple):
        from kr210_sim.sandbox.perception_sandbox import open_perception
        from kr210_sim.sensors.user_perceiver import user_perceiver

        return user_perceiver(open_perception(*perceive))
    return _perceiver


def _perceiver(model: mujoco.MjModel, planner: Planner) -> Perceiver:
    """A perceiver of ``model`` with the cell's recogniser (read or trained once a process:
    :func:`~kr210_sim.sensors.recognisers.recogniser_for` keeps it)."""
    from kr210_sim.sensors.perceiver import Perceiver
    from kr210_sim.sensors.recognisers import recogniser_for

    return Perceiver(model, planner, recogniser_for(model))


def run_episode(
    seed: int,
    randomize: bool,
    scene: Path | str | None = None,
    ik: str | None = None,
    ik_timeout: float | None = None,
    perceive: Perceive = False,
) -> CycleResult:
    """One episode on a fresh copy of this process's model of ``scene``, planned with the IK of
    SPEC ``ik`` (None: ours; loaded once per process; with ``ik_timeout`` [s] in a process of
    its own, :func:`~kr210_sim.sandbox.guarded.load_user_ik`), from what the sensors saw
    when ``perceive``."""
    user_ik = None
    if ik is not None:
        from kr210_sim.sandbox.guarded import load_user_ik

        user_ik = load_user_ik(ik, ik_timeout)
    runner = episode_runner(
        seed,
        randomize=randomize,
        model=load_pristine(scene),
        ik=user_ik,
        perceiver=perceiver_factory(perceive) if perceive else None,
    )
    try:
        return runner.run_cycle(1, runner.slot_for_cycle())
    finally:
        close = getattr(runner.perceiver, "close", None)
        if close is not None:
            close()  # its renderers' GL contexts: one episode's


def episode_record(index: int, seed: int, r: CycleResult) -> dict[str, Any]:
    """The record of one episode (a line of the episodes file; failures also in the report): the
    cycle record (:func:`kr210_sim.score.result.cycle_record`, as ``run`` reports a cycle) with
    the episode's number and seed in front."""
    return {"episode": index, "seed": seed, **cycle_record(r)}


def record_of(
    index: int,
    seed: int,
    randomize: bool,
    scene: Path | str | None,
    ik: str | None = None,
    ik_timeout: float | None = None,
    perceive: Perceive = False,
) -> dict[str, Any]:
    """Run episode ``index`` (seeded ``seed``) and return its record."""
    r = run_episode(seed, randomize, scene, ik, ik_timeout, perceive)
    return episode_record(index, seed, r)


def run_chunk(
    jobs: Sequence[tuple[int, int]],
    randomize: bool,
    scene: str | None,
    ik: str | None = None,
    ik_timeout: float | None = None,
    perceive: Perceive = False,
) -> dict[str, Any]:
    """Run a chunk of episodes: the unit of work a backend ships to a worker.

    Args:
        jobs: ``(index, seed)`` of each episode.
        randomize: Randomise each episode's target.
        scene: MJCF scene path (must exist where this runs), or None for the committed scene.
        ik: SPEC of the user's IK (its file or module must exist where this runs), or None.
        ik_timeout: Time limit per call of that IK [s] (it then runs in a process of its own).
        perceive: Pick from what the cell's sensors see (``--perceive``; with ``(SPEC,
            timeout)`` by the user's function, ``--perception``).

    Returns:
        ``{"records": [record, ...], "versions": {...}}``: the records in ``jobs`` order and the
        library versions of the process that ran them (the driver refuses mixed versions, which
        would break the episodes' purity).
    """
    from kr210_sim.util.versions import versions

    return {
        "records": [record_of(i, s, randomize, scene, ik, ik_timeout, perceive) for i, s in jobs],
        "versions": versions(),
    }
