"""PNG plots of a run."""

from __future__ import annotations

from pathlib import Path

import imageio.v3 as iio
import pytest

from kr210_sim.errors import ConfigError
from kr210_sim.media.plots import write_plots
from kr210_sim.sim.runner import RunConfig, Runner


@pytest.fixture(scope="module")
def runner() -> Runner:
    r = Runner(RunConfig(cycles=2, seed=1), keep_recordings=True)
    for i in (1, 2):
        r.run_cycle(i, r.slot_for_cycle())
    return r


def test_four_plots_are_written(tmp_path: Path, runner: Runner) -> None:
    paths = write_plots(tmp_path / "plots", runner.results, runner.recordings, runner.robot)
    names = [p.name for p in paths]
    assert names == [
        "tracking_error.png",
        "gripper_error.png",
        "joint_limits.png",
        "cycle_times.png",
    ]
    for p in paths:
        img = iio.imread(p)
        assert img.shape[0] > 300 and img.shape[1] > 800
        assert img[..., :3].std() > 10  # something is drawn


def test_unwritable_plot_folder(tmp_path: Path, runner: Runner) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("")
    with pytest.raises(ConfigError, match="cannot create the folder"):
        write_plots(blocker / "plots", runner.results, runner.recordings, runner.robot)
