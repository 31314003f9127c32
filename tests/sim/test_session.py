"""One episode's setup (a fresh runner for one cycle with one seed) and the one cycle loop of
``run`` and ``view``."""

from __future__ import annotations

import io

import numpy as np

from kr210_sim.cell.load import load_model
from kr210_sim.sim.cell import Cell
from kr210_sim.sim.runner import RunConfig
from kr210_sim.sim.session import episode_runner, run_session


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


def test_the_session_runs_the_cycles_with_its_hooks_and_removes_them() -> None:
    runner = episode_runner(0, slot=5)
    ticks: list[float] = []
    phases: list[str] = []
    after: list[int] = []
    out = io.StringIO()
    end = run_session(
        runner,
        out,
        hooks=[lambda cell: ticks.append(cell.time)],
        on_phase=phases.append,
        after=after.append,
        closing=lambda: runner.idle(0.5),
    )
    assert end.interrupted is None and end.wall_time > 0
    assert runner.cell.hooks == [] and runner.on_phase is None
    assert out.getvalue().startswith("[1/1] slot 5  ok") and after == [1]
    assert runner.plan is not None  # the gate hook saw every step of the plan, in order
    assert phases == [s.phase for s in runner.plan.steps]
    assert ticks[-1] == runner.cell.time  # the closing shot ran under the hooks
    assert ticks[-1] - runner.results[0].cycle_time > 0.5


def test_an_interrupt_ends_the_session_and_is_returned() -> None:
    runner = episode_runner(0, slot=5)

    def stop(cell: Cell) -> None:
        if cell.time > 1.0:
            raise KeyboardInterrupt

    end = run_session(runner, io.StringIO(), hooks=[stop])
    assert isinstance(end.interrupted, KeyboardInterrupt)
    assert runner.results == [] and runner.cell.hooks == []
    assert 1.0 < runner.cell.time < 1.01
