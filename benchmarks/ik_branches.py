"""Why cycles with a ROS-form server can be longer than with the built-in IK (issue 42 item 3):
the same slots run with the built-in IK and with three ROS-form servers, and what the reports say.

Run: ``python benchmarks/ik_branches.py [--cycles 6] [--seed 0] [--cell PATH]``. Prints figures
only.

The servers are built at run time from the forms of ``tests/ros_class.py`` (correct closed-form
IK, Python 2): ``nearest-last`` keeps its last answer and returns the solution nearest it (as
MoveIt's paths needed), ``nearest-zero`` the solution nearest all-zero joints, ``fixed-wrist``
the first solution it finds, the same wrist (theta5 >= 0) whatever the arm's state. Each runs
as ``run --ik`` runs it (its own jailed process, poses in batches).

Printed per IK: the mean simulated cycle time, the carry and return phases, the wall-clock
planning time per cycle, the IK's calls and time per call, and the report's
``summary.ik.branches``: answers on another branch than the built-in IK's and the time they add
(a lower bound).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path
from statistics import mean

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from ros_class import _stateless, numpy_server


def servers() -> dict[str, str]:
    """The ROS-form servers by name."""
    last = numpy_server()
    fixed = last.replace(
        "            for k4 in xrange(-2, 3):\n                for k6 in xrange(-2, 3):",
        "            for k4 in xrange(0, 1):\n                for k6 in xrange(0, 1):",
    ).replace("if best is None or d < best[0]:", "if best is None:")
    return {"nearest-last": last, "nearest-zero": _stateless(last), "fixed-wrist": fixed}


def run(args: list[str], report: Path) -> dict:
    """``run`` with ``args``; its report."""
    cmd = [sys.executable, "-m", "kr210_sim", "run", *args, "--report", str(report)]
    subprocess.run(cmd, check=True, capture_output=True, text=True)
    return json.loads(report.read_text())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--cycles", type=int, default=6, help="cycles per IK (6)")
    ap.add_argument("--seed", type=int, default=0, help="seed: the same slots for every IK (0)")
    ap.add_argument("--cell", type=Path, default=None, help="cell file (the committed scene)")
    a = ap.parse_args()
    common = ["--cycles", str(a.cycles), "--seed", str(a.seed)]
    if a.cell is not None:
        common += ["--cell", str(a.cell)]
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        runs = {"built-in": run(common, d / "builtin.json")}
        for name, source in servers().items():
            script = d / name / "kuka_arm" / "scripts" / "IK_server.py"
            script.parent.mkdir(parents=True)
            script.write_text(source)
            runs[name] = run([*common, "--ik", str(d / name)], d / f"{name}.json")
    print(
        f"{a.cycles} cycles, seed {a.seed}, slots {[c['slot'] for c in runs['built-in']['cycles']]}"
    )
    for name, report in runs.items():
        s, cycles = report["summary"], report["cycles"]
        carry = mean(c["phase_times"]["carry"] for c in cycles)
        ret = mean(c["phase_times"]["return"] for c in cycles)
        line = (
            f"{name:13s} cycle {s['cycle_time_mean']:.2f} s (carry {carry:.2f}, return {ret:.2f})"
            f"  planning {s['wall_planning_time_s']['mean']:.3f} s/cycle"
        )
        ik = s.get("ik")
        if ik is not None:
            b = ik["branches"]
            line += (
                f"  IK {ik['calls']} calls, {1e3 * ik['wall_time_s']['per_call_mean']:.1f} ms"
                f"/call  other branch {b['other_branch']}/{b['answered']}"
                f" (+{b['extra_s_per_cycle']:.2f} s/cycle at least)"
            )
        print(line)
        if ik is not None and ik["branches"]["other_branch"]:
            print(f"{'':13s} note: {ik['branches']['note']}")


if __name__ == "__main__":
    main()
