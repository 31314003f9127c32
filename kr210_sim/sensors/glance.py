"""One look at a cycle's start, kept for pictures (``python -m kr210_sim perceive``).

:func:`glance` sets the cell up as ``run --perceive --cycles 1`` starts its first cycle (the
same seed, slot, randomisation and clutter), lets the perceiver look at the target's bay (the
fixed sensor, and the wrist camera when the first look was not sure: the arm moves there), and
keeps what the sensors saw, what the pipeline made of it and the truth it is scored against.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from kr210_sim.errors import NotSeenError
from kr210_sim.perception.camera import Observation
from kr210_sim.perception.pipeline import Percept
from kr210_sim.plan.cycle import Move
from kr210_sim.sensors.perceiver import Perceiver
from kr210_sim.sensors.truth import TruthObject, shelf_truth
from kr210_sim.sim.perceived import PerceptionRecord
from kr210_sim.sim.session import episode_runner

import mujoco  # isort: skip


@dataclass(frozen=True)
class Glance:
    """What one cycle's look saw.

    Attributes:
        slot: The slot looked at (1-based).
        label: The kind the pick list asked for.
        observations: Each look's observation, in order (the fixed sensor's first).
        percept: What the pipeline made of them.
        record: That percept scored against the truth.
        truth: Every object on the shelf at the look (for scoring and pictures only).
        target_body: The body id of the cycle's target (in ``truth``).
    """

    slot: int
    label: str
    observations: tuple[Observation, ...]
    percept: Percept
    record: PerceptionRecord
    truth: tuple[TruthObject, ...]
    target_body: int


def glance(
    cell: Path | str | None = None, seed: int = 0, slot: int = 0, randomize: bool = False
) -> Glance:
    """Look at the first cycle's target of ``run --perceive --cycles 1 --seed seed`` in ``cell``.

    Args:
        cell: A cell file (``.toml``) or MJCF scene; None: the committed scene.
        seed: The run's seed (draws the slot, the target and, with ``randomize``, the clutter).
        slot: Slot 1..n, or 0 for the one the seed draws.
        randomize: As ``run --randomize``.

    Raises:
        ConfigError: A slot outside the cell, or a cell without a fixed sensor.
        SceneError: The cell cannot be loaded.
    """
    from kr210_sim.cell.load import model_at

    runner = episode_runner(
        seed, randomize=randomize, slot=slot, model=model_at(cell), perceiver=Perceiver
    )
    perceiver = runner.perceiver
    assert isinstance(perceiver, Perceiver)
    try:
        sample, k = runner.start_cycle(1, runner.slot_for_cycle())

        def track(move: Move) -> None:  # the wrist look's move, as the runner follows it
            runner.cell.track(move.trajectory, None, move.phase)
            runner.q_cmd = move.q_end

        try:
            perceiver.look(runner.cell, k, sample, runner.clutter.kind, runner.q_cmd, track)
        except NotSeenError:
            pass  # drawn all the same: the record says why
        assert perceiver.record is not None and perceiver.percept is not None
        mujoco.mj_forward(runner.model, runner.cell.data)
        truth = shelf_truth(runner.model, runner.cell.data, perceiver.layout)
        return Glance(
            slot=sample.slot,
            label=runner.clutter.kind,
            observations=perceiver.observations,
            percept=perceiver.percept,
            record=perceiver.record,
            truth=tuple(truth),
            target_body=int(runner.cell.handles.target_bodies[k]),
        )
    finally:
        perceiver.close()
