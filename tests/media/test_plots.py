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


def test_cycle_time_legend_patches_have_the_bars_colours(runner: Runner) -> None:
    import dataclasses

    import matplotlib.pyplot as plt
    from matplotlib.colors import to_rgba

    from kr210_sim.media.plots import OUTCOME_COLOURS, cycle_times_figure

    ok = runner.results[0]
    failed = dataclasses.replace(runner.results[1], success=False, reason="collision")
    fig = cycle_times_figure([ok, failed])
    try:
        ax = fig.axes[0]
        bars = {p.get_x() + p.get_width() / 2: p.get_facecolor() for p in ax.patches}
        legend = ax.get_legend()
        colours = {
            t.get_text(): h.get_facecolor()
            for t, h in zip(legend.get_texts(), legend.legend_handles, strict=True)
        }
    finally:
        plt.close(fig)
    assert bars[ok.index] == to_rgba(OUTCOME_COLOURS[None])
    assert bars[failed.index] == to_rgba(OUTCOME_COLOURS["collision"])
    assert colours == {"success": bars[ok.index], "collision": bars[failed.index]}
