"""One episode's setup: a fresh runner for one cycle with one seed.

An evaluation episode, its re-run for a recording, the README's pictures and a Gymnasium
episode are all "one cycle of ``RunConfig(cycles=1, seed=seed, ...)`` in a fresh cell":
:func:`episode_runner` builds it, so they draw the same slot and target for the same seed and
plan with the same planner, collision checks and drop spot as ``run``.
"""

from __future__ import annotations

import copy

import numpy as np

from kr210_sim.robot.description import RobotDescription
from kr210_sim.robot.user_ik import UserIk
from kr210_sim.sim.runner import RunConfig, Runner

import mujoco  # isort: skip


def episode_runner(
    seed: int = 0,
    *,
    randomize: bool = False,
    slot: int = 0,
    model: mujoco.MjModel | None = None,
    copy_model: bool = True,
    robot: RobotDescription | None = None,
    ik: UserIk | None = None,
    keep_recordings: bool = False,
    rng: np.random.Generator | None = None,
) -> Runner:
    """A fresh runner for one cycle of ``RunConfig(cycles=1, seed=seed, slot=slot,
    randomize=randomize)``: the arm at the ready pose, every target spare, the bin empty.

    Its first cycle (``runner.run_cycle(1, runner.slot_for_cycle())``) is the episode; it is
    the first cycle of ``run --cycles 1 --seed <seed>`` with the same options.

    Args:
        seed: The episode's seed.
        randomize: Randomise the target (as ``run --randomize``).
        slot: Slot 1..n, or 0 for a slot drawn from the seed.
        model: The cell's model (default: the committed scene, loaded).
        copy_model: Run on a copy of ``model`` (a pristine model stays pristine: the runner
            sets the targets' sizes in the model it runs). False: run on ``model`` itself.
        robot: The robot description (default: the committed URDF).
        ik: A user's IK function to plan with (default: our closed form).
        keep_recordings: Keep the cycle's per-tick recording (for plots).
        rng: The generator the slot and target are drawn from, instead of one seeded with
            ``seed`` (a Gymnasium environment passes its own ``np_random``).

    Raises:
        ConfigError: A slot outside the cell.
    """
    config = RunConfig(cycles=1, seed=seed, slot=slot, randomize=randomize)
    if model is not None and copy_model:
        model = copy.copy(model)
    return Runner(config, model=model, robot=robot, keep_recordings=keep_recordings, ik=ik, rng=rng)
