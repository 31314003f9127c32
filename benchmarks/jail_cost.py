"""What the jail costs: start-up per student, time per call, and a correct student's CPU time.

Run: ``python benchmarks/jail_cost.py [--starts N] [--calls N] [--cases N] [--cycles N]
[--repeats N]``. Prints figures only; jailed and unjailed alternate in one sitting, so compare
the differences, not the absolute times across days (the 2-core machine is shared).

* Start-up: ``examples/ik_dh.py``'s sandbox started until its module is imported and it says
  ready, in the jail (:class:`~kr210_sim.sandbox.jail.Jail`: bubblewrap, the namespaces, the
  control group, the scratch tmpfs) and without (:class:`~kr210_sim.sandbox.confine.Unconfined`):
  the wall time, the CPU time of a start and an end (every process counted: the jail's are read
  from ``/proc`` before they are killed), and what ending it takes (count, kill, wait). Target:
  at most 0.5 s more per student.
* Per call: a round trip over the pipe to the same function, jailed and unjailed.
* One correct student: ``grade examples/ik_dh.py`` with and without ``--no-jail``: the CPU time of
  the whole command (the grader, the student's grading process, bubblewrap and the student's
  process, all reaped) and its wall time. Target: the jail adds at most 10 % of that CPU time.
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from kr210_sim.robot import kinematics
from kr210_sim.sandbox.confine import Confinement, Unconfined
from kr210_sim.sandbox.ik_sandbox import IkSandbox
from kr210_sim.sandbox.jail import Jail

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "ik_dh.py"
SPEC = f"{EXAMPLE}:solve"


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _own_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def start_up(starts: int) -> None:
    times: dict[str, list[float]] = {"none": [], "bwrap": []}
    ends: dict[str, list[float]] = {"none": [], "bwrap": []}
    cpu: dict[str, list[float]] = {"none": [], "bwrap": []}
    jail = Jail()
    for _ in range(starts):
        for confinement in (Unconfined(), jail):
            c: Confinement = confinement
            box = IkSandbox(SPEC, confinement=c, root=EXAMPLE)
            used = _own_cpu() + _children_cpu() + jail.cpu_s
            t = time.perf_counter()
            box.start()
            times[c.name].append(time.perf_counter() - t)
            t = time.perf_counter()
            box.close()
            ends[c.name].append(time.perf_counter() - t)
            cpu[c.name].append(_own_cpu() + _children_cpu() + jail.cpu_s - used)
    out, jailed = statistics.median(times["none"]), statistics.median(times["bwrap"])
    print(f"start-up, unjailed (median of {starts})   {out:6.3f} s")
    print(f"start-up, jailed                  {jailed:6.3f} s  (+{jailed - out:.3f} s)")
    c_out, c_in = statistics.median(cpu["none"]), statistics.median(cpu["bwrap"])
    print(f"CPU of a start and end, unjailed  {c_out:6.3f} s")
    print(f"CPU of a start and end, jailed    {c_in:6.3f} s  ({c_in - c_out:+.3f} s)")
    end_out, end_in = statistics.median(ends["none"]), statistics.median(ends["bwrap"])
    print(f"end, unjailed / jailed            {end_out:6.3f} s / {end_in:.3f} s")
    d = jail.describe()
    print(f"jail: bwrap {d['bwrap']}; processes: {d['processes']}; cpu: {d['cpu']}")
    print(f"      memory: {d['memory']}")


def per_call(calls: int) -> None:
    g = kinematics.committed().geometry
    qs = np.random.default_rng(0).uniform(g.lower, g.upper, size=(calls, 6))
    poses = [kinematics.forward(q) for q in qs]
    for confinement in (Unconfined(), Jail()):
        c: Confinement = confinement
        with IkSandbox(SPEC, confinement=c, root=EXAMPLE) as box:
            box.start()
            t = time.perf_counter()
            for T, q in zip(poses, qs, strict=True):
                box(T, q)
            each = (time.perf_counter() - t) / calls
        print(f"per call, {'jailed' if c.name == 'bwrap' else 'unjailed':8}  {1e6 * each:8.0f} us")


def one_student(cases: int, cycles: int, repeats: int) -> None:
    cpu: dict[bool, list[float]] = {True: [], False: []}
    wall: dict[bool, list[float]] = {True: [], False: []}
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(repeats):
            for jailed in (False, True):
                argv = [sys.executable, "-m", "kr210_sim", "grade", str(EXAMPLE)]
                argv += ["--cases", str(cases), "--cycles", str(cycles)]
                argv += ["--report", str(Path(tmp) / "grade.json")]
                if not jailed:
                    argv.append("--no-jail")
                c, t = _children_cpu(), time.perf_counter()
                done = subprocess.run(argv, capture_output=True, text=True)
                wall[jailed].append(time.perf_counter() - t)
                if done.returncode != 0:
                    sys.exit(f"grade failed ({done.returncode}): {done.stderr or done.stdout}")
                # The jail's processes die with its init, reaped by nobody of ours: the grading
                # process read their CPU time from /proc before it ended them.
                record = json.loads((Path(tmp) / "grade.json").read_text())["students"][0]
                inside = record["jail"].get("cpu_s", 0.0)
                cpu[jailed].append(_children_cpu() - c + inside)
    out, jailed_cpu = statistics.median(cpu[False]), statistics.median(cpu[True])
    print(f"one correct student ({cases} random cases, {cycles} cycles), median of {repeats}:")
    print(
        f"  CPU, unjailed                   {out:6.2f} s  (wall "
        f"{statistics.median(wall[False]):.2f} s)"
    )
    print(
        f"  CPU, jailed                     {jailed_cpu:6.2f} s  (wall "
        f"{statistics.median(wall[True]):.2f} s)"
    )
    print(f"  the jail's share                {100 * (jailed_cpu - out) / out:+6.1f} %")
    runs = " / ".join(", ".join(f"{v:.2f}" for v in cpu[j]) for j in (False, True))
    print(f"  every run's CPU, unjailed / jailed: {runs} s")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--starts", type=int, default=10)
    p.add_argument("--calls", type=int, default=2000)
    p.add_argument("--cases", type=int, default=1000)
    p.add_argument("--cycles", type=int, default=10)
    p.add_argument("--repeats", type=int, default=3)
    args = p.parse_args()
    start_up(args.starts)
    per_call(args.calls)
    one_student(args.cases, args.cycles, args.repeats)


if __name__ == "__main__":
    main()
