"""What the motion settings do to the grip: creep, the lips' load, cycle time against the bound.

Runs ten ten-cycle runs (seeds 0-9) in the published cell for each of a few motion settings and
prints, side by side in one run, over their cycles: successes, the mean cycle time, the moves'
duration over their lower bound (mean per cycle), the target's creep in the gripper (mean / p95
/ max), the share of the carry's ticks in which a fingertip lip touches the cylinder, the
largest lip normal force per cycle (mean / p95 / max) and the largest joint tracking error.
(One cycle's largest lip force moves by a fifth when anything before the carry is timed
differently: compare means and p95 over many cycles.) The
settings: the jerk limit of the joint moves with the gripper empty (to the standoff, back to the
ready pose) at 12, what every move had before, and at the default (24); the moves into, with and
out of the grip at 12 in both (``MotionConfig.grip_jerk_scale``).

Run: python benchmarks/grip_load.py [--quick] [--seeds N] [--cycles N] [--default-only]
(--quick: seeds 0-1; --default-only: the default setting alone). The MuJoCo version is printed
first: the contacts of the lips depend on it (4.0.1 changed cylinder-edge multicontact).
"""

from __future__ import annotations

import argparse

import mujoco
import numpy as np

from kr210_sim.cell.spec import MotionConfig
from kr210_sim.sim.cell import Cell
from kr210_sim.sim.runner import RunConfig, Runner

SETTINGS = (
    ("all moves jerk 12", MotionConfig(jerk_scale=12.0)),
    ("default", MotionConfig()),
)


def measure(motion: MotionConfig, seed: int, cycles: int = 10) -> dict[str, list[float]]:
    """Per-cycle figures of one run (see the module doc)."""
    runner = Runner(RunConfig(cycles=cycles, seed=seed, motion=motion))
    m, d = runner.cell.model, runner.cell.data
    lips = {m.geom("left_finger_lip").id, m.geom("right_finger_lip").id}
    targets = {int(g) for g in runner.cell.handles.target_geoms}
    force = np.zeros(6)
    carry = {"ticks": 0, "lip_ticks": 0, "force": 0.0}

    def hook(cell: Cell) -> None:
        if cell.phase != "carry":
            return
        carry["ticks"] += 1
        touching = False
        for i in range(d.ncon):
            g1, g2 = int(d.contact.geom1[i]), int(d.contact.geom2[i])
            if (g1 in lips and g2 in targets) or (g2 in lips and g1 in targets):
                mujoco.mj_contactForce(m, d, i, force)
                carry["force"] = max(carry["force"], abs(float(force[0])))
                touching = True
        carry["lip_ticks"] += touching

    runner.cell.hooks.append(hook)
    out: dict[str, list[float]] = {k: [] for k in ("ok", "cycle", "ratio", "creep", "lip", "force")}
    out["track"] = []
    for i in range(1, cycles + 1):
        carry.update(ticks=0, lip_ticks=0, force=0.0)
        r = runner.run_cycle(i, runner.slot_for_cycle())
        out["ok"].append(float(r.success))
        out["cycle"].append(r.cycle_time)
        out["ratio"].append(sum(mv[2] for mv in r.moves) / sum(mv[3] for mv in r.moves))
        out["creep"].append(r.creep_mm)
        out["lip"].append(carry["lip_ticks"] / max(carry["ticks"], 1))
        out["force"].append(carry["force"])
        out["track"].append(max(r.max_tracking_error_deg))
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="seeds 0-1 (as --seeds 2)")
    parser.add_argument("--seeds", type=int, default=10, help="runs, seeds 0..N-1 (default 10)")
    parser.add_argument("--cycles", type=int, default=10, help="cycles a run (default 10)")
    parser.add_argument("--default-only", action="store_true", help="the default setting only")
    args = parser.parse_args(argv)
    if args.seeds < 1 or args.cycles < 1:
        parser.error("--seeds and --cycles must be at least 1")
    seeds = range(2) if args.quick else range(args.seeds)
    settings = SETTINGS[-1:] if args.default_only else SETTINGS
    print(f"MuJoCo {mujoco.__version__}, seeds 0-{seeds[-1]}, {args.cycles} cycles each")
    print(
        f"{'setting':<18} {'ok':>7} {'cycle s':>7} {'/bound':>6} "
        f"{'creep mm mean/p95/max':>21} {'lip in carry':>12} {'lip N mean/p95/max':>18} "
        f"{'track deg':>9}"
    )
    for name, motion in settings:
        f: dict[str, list[float]] = {}
        for seed in seeds:
            for k, v in measure(motion, seed, args.cycles).items():
                f.setdefault(k, []).extend(v)
        creep, force = np.array(f["creep"]), np.array(f["force"])
        print(
            f"{name:<18} {int(sum(f['ok'])):>3}/{len(f['ok']):<3} "
            f"{np.mean(f['cycle']):>7.3f} {np.mean(f['ratio']):>6.3f} "
            f"{creep.mean():>7.2f} /{np.percentile(creep, 95):>5.2f} /{creep.max():>5.2f} "
            f"{100 * np.mean(f['lip']):>11.0f}% "
            f"{force.mean():>6.1f} /{np.percentile(force, 95):>5.1f} /{force.max():>5.1f} "
            f"{np.max(f['track']):>9.3f}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
