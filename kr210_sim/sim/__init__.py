"""The stepped cell: MuJoCo's model and data under control, the runner that executes cycles,
targets."""

from __future__ import annotations

from kr210_sim.sim.cell import Cell
from kr210_sim.sim.runner import RunConfig, Runner
from kr210_sim.sim.session import episode_runner, run_session

__all__ = [
    "Cell",
    "RunConfig",
    "Runner",
    "episode_runner",
    "run_session",
]
