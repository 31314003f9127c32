"""PNG plots of a run (matplotlib, headless): what a report's numbers look like over time.

* ``tracking_error.png``: |q_des - q| per joint over simulated time [deg].
* ``gripper_error.png``: the joint tracking error seen at the gripper (gripper position at the
  measured joints against the commanded ones), one curve per cycle [mm].
* ``joint_limits.png``: joint positions and velocities against their limits.
* ``cycle_times.png``: cycle time per cycle, coloured by outcome.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from kr210_sim.robot.description import ARM_JOINTS, RobotDescription
from kr210_sim.robot.kinematics import Kinematics
from kr210_sim.score.metrics import gripper_tracking_error_mm
from kr210_sim.score.result import CycleResult
from kr210_sim.sim.cell import TickLog
from kr210_sim.util.outputs import atomic_path, check_folder

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#: The files :func:`write_plots` writes.
PLOT_NAMES = ("tracking_error.png", "gripper_error.png", "joint_limits.png", "cycle_times.png")

OUTCOME_COLOURS = {
    None: "#2a9d4b",
    "unreachable": "#7f7f7f",
    "collision": "#d62728",
    "knocked_over": "#e377c2",
    "grasp_missed": "#ff7f0e",
    "dropped_in_transit": "#9467bd",
    "missed_bin": "#8c564b",
    "ik_failed": "#17becf",
    "no_path": "#bcbd22",
    "not_settled": "#c49c94",
    "not_seen": "#aec7e8",
    "wrong_object": "#ff9896",
    "grasp_missed_estimate_off": "#ffbb78",
}


def write_plots(
    out_dir: Path | str,
    results: Sequence[CycleResult],
    recordings: Sequence[TickLog],
    robot: RobotDescription,
) -> list[Path]:
    """Write the four plots into ``out_dir``; return their paths.

    Raises:
        ConfigError: When ``out_dir`` cannot be created or written.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    kin = Kinematics(robot)

    out = check_folder(out_dir, PLOT_NAMES)
    arrays = [rec.arrays() for rec in recordings]
    paths: list[Path] = []

    def save(fig: object, name: str) -> None:
        path = out / name
        try:
            with atomic_path(path) as tmp:
                fig.savefig(tmp, dpi=110, format="png")  # type: ignore[attr-defined]
        finally:
            plt.close(fig)  # type: ignore[arg-type]
        paths.append(path)

    # 1. tracking error per joint
    fig, axes = plt.subplots(6, 1, figsize=(10, 9), sharex=True)
    for a in arrays:
        err = np.degrees(np.abs(a["q_des"] - a["q"]))
        for j, ax in enumerate(axes):
            ax.plot(a["t"], err[:, j], lw=0.7, color="C0")
    for j, ax in enumerate(axes):
        ax.set_ylabel(f"{ARM_JOINTS[j]}\n[deg]", fontsize=8)
        ax.grid(alpha=0.3)
    axes[0].set_title("Joint tracking error |q_des - q|")
    axes[-1].set_xlabel("simulated time [s]")
    fig.tight_layout()
    save(fig, "tracking_error.png")

    # 2. gripper position error against the plan, per cycle
    fig, ax = plt.subplots(figsize=(10, 4.5))
    for r, a in zip(results, arrays, strict=True):
        if not len(a["t"]):
            continue
        err = gripper_tracking_error_mm(kin, a["q"], a["q_des"])
        ax.plot(a["t"] - a["t"][0], err, lw=0.8, label=f"cycle {r.index} (slot {r.slot})")
    ax.set_xlabel("time in cycle [s]")
    ax.set_ylabel("gripper tracking error [mm]")
    ax.set_title("Joint tracking error seen at the gripper (measured vs commanded joints)")
    ax.grid(alpha=0.3)
    if results:
        ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    save(fig, "gripper_error.png")

    # 3. joint positions and velocities against their limits
    fig, axes = plt.subplots(6, 2, figsize=(12, 10), sharex=True)
    for a in arrays:
        for j in range(6):
            axes[j, 0].plot(a["t"], np.degrees(a["q"][:, j]), lw=0.7, color="C0")
            axes[j, 1].plot(a["t"], np.degrees(a["qd"][:, j]), lw=0.7, color="C1")
    for j in range(6):
        for lim in (robot.q_lower[j], robot.q_upper[j]):
            axes[j, 0].axhline(np.degrees(lim), color="r", ls="--", lw=0.8)
        for lim in (-robot.qd_max[j], robot.qd_max[j]):
            axes[j, 1].axhline(np.degrees(lim), color="r", ls="--", lw=0.8)
        axes[j, 0].set_ylabel(f"{ARM_JOINTS[j]}\n[deg]", fontsize=8)
        axes[j, 1].set_ylabel("[deg/s]", fontsize=8)
    axes[0, 0].set_title("Joint positions (limits dashed)")
    axes[0, 1].set_title("Joint velocities (limits dashed)")
    axes[-1, 0].set_xlabel("simulated time [s]")
    axes[-1, 1].set_xlabel("simulated time [s]")
    fig.tight_layout()
    save(fig, "joint_limits.png")

    # 4. cycle times by outcome
    fig = cycle_times_figure(results)
    save(fig, "cycle_times.png")
    return paths


def cycle_times_figure(results: Sequence[CycleResult]) -> Figure:
    """The cycle-time bar chart: one bar per cycle [s], coloured by outcome, with a legend.

    The legend's entries are patches of the bars' own colours (an empty ``bar()`` call gives a
    legend handle in the default colour, not the bars').
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    fig, ax = plt.subplots(figsize=(10, 4))
    ax.bar(
        [r.index for r in results],
        [r.cycle_time for r in results],
        color=[OUTCOME_COLOURS.get(r.reason, "k") for r in results],
    )
    handles = [
        Patch(facecolor=colour, label=reason or "success")
        for reason, colour in OUTCOME_COLOURS.items()
        if any(r.reason == reason for r in results)
    ]
    ax.set_xlabel("cycle")
    ax.set_ylabel("cycle time [s]")
    ax.set_title("Cycle time by outcome")
    if handles:
        ax.legend(handles=handles, fontsize=8)
    ax.grid(alpha=0.3, axis="y")
    fig.tight_layout()
    return fig
