"""One episode's setup: a fresh runner for one cycle with one seed."""

from __future__ import annotations

import numpy as np

from kr210_sim.cell.load import load_model
from kr210_sim.sim.runner import RunConfig
from kr210_sim.sim.session import episode_runner


def test_an_episode_runs_on_a_copy_of_the_pristine_model() -> None:
    pristine = load_model()
    before = pristine.geom_size.copy()
    runner = episode_runner(7, randomize=True, model=pristine)
    runner.start_cycle(1, runner.slot_for_cycle())
    assert runner.config == RunConfig(cycles=1, seed=7, randomize=True)
    assert runner.model is not pristine and np.array_equal(pristine.geom_size, before)
    assert not np.array_equal(runner.model.geom_size, before)  # the drawn target's size
    assert episode_runner(7, model=pristine, copy_model=False).model is pristine


def test_the_seed_or_a_given_generator_draws_the_slot_and_target() -> None:
    a = episode_runner(11, randomize=True)
    b = episode_runner(0, randomize=True, rng=np.random.default_rng(11))
    sa, _ = a.start_cycle(1, a.slot_for_cycle())
    sb, _ = b.start_cycle(1, b.slot_for_cycle())
    assert sa == sb
    c = episode_runner(12, randomize=True)
    assert c.start_cycle(1, c.slot_for_cycle())[0] != sa
