"""What the sandbox costs, and the time to grade one correct student.

Run: ``python benchmarks/grade.py [--calls N] [--cases N] [--cycles N]``. Prints figures only.

* Per call: ``examples/ik_dh.py``'s ``solve`` called in this process against the same function
  in an :class:`~kr210_sim.sandbox.ik_sandbox.IkSandbox` (a round trip over a pipe), on the same
  poses, in one sitting: compare the ratio, not the absolute times across days.
* Start: the sandbox's process started and the module imported (before the first call).
* One student: ``grade examples/ik_dh.py`` (ik-check of the fixed poses and ``--cases`` random
  ones, a run of ``--cycles`` cycles), wall and CPU time of the whole command (the grader, the
  student's grading process and its sandbox), and the student's own figures from the report:
  its own time (what ``--timeout`` bounds: its process started, its module imported, its calls
  answered) against the grading process's whole time.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from kr210_sim.robot import kinematics
from kr210_sim.sandbox.ik_sandbox import IkSandbox
from kr210_sim.sandbox.user_ik import load_ik

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "ik_dh.py"


def per_call(calls: int) -> None:
    g = kinematics.committed().geometry
    qs = np.random.default_rng(0).uniform(g.lower, g.upper, size=(calls, 6))
    poses = [kinematics.forward(q) for q in qs]
    here = load_ik(f"{EXAMPLE}:solve").function
    t0 = time.perf_counter()
    with IkSandbox(f"{EXAMPLE}:solve") as box:
        box.start()
        start = time.perf_counter() - t0
        t = time.perf_counter()
        for T, q in zip(poses, qs, strict=True):
            box(T, q)
        apart = (time.perf_counter() - t) / calls
    t = time.perf_counter()
    for T, q in zip(poses, qs, strict=True):
        here(T, q)
    inside = (time.perf_counter() - t) / calls
    print(f"per call, in this process      {1e6 * inside:8.0f} us  ({calls} calls)")
    print(f"per call, in the sandbox       {1e6 * apart:8.0f} us  ({apart / inside:.2f}x)")
    print(f"round trip over the pipe       {1e6 * (apart - inside):8.0f} us")
    print(f"sandbox start (import + load)  {start:8.2f} s")


def one_student(cases: int, cycles: int) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        report = Path(tmp) / "grade.json"
        cmd = [sys.executable, "-m", "kr210_sim", "grade", str(EXAMPLE), "--workers", "1"]
        cmd += ["--cases", str(cases), "--cycles", str(cycles), "--report", str(report)]
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t = time.perf_counter()
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
        wall = time.perf_counter() - t
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
        s = json.loads(report.read_text())["students"][0]
    w = s["wall_time_s"]
    print(
        f"one correct student            {wall:8.1f} s wall, {cpu:.1f} s CPU for the command "
        f"({s['ik_check']['cases']} ik-check poses + {cycles} cycles: {s['verdict']})"
    )
    print(
        f"  its grading process          {w['total']:8.1f} s (ik-check {w['ik_check']:.1f} s, "
        f"run {w['run']:.1f} s)"
    )
    if w.get("student") is not None:  # what --timeout counts
        print(f"  the student's own time       {w['student']:8.2f} s (import and calls)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=500)
    parser.add_argument("--cases", type=int, default=1000)
    parser.add_argument("--cycles", type=int, default=10)
    args = parser.parse_args()
    per_call(args.calls)
    one_student(args.cases, args.cycles)


if __name__ == "__main__":
    main()
