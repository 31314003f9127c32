"""Grade a class of original-form submissions with the default settings, in one call: the time
it takes (issue 31's target: 30 students in at most 25 min of wall time on a 2-core machine).

Run: ``python benchmarks/grade_ros.py [--students 30] [--keep DIR] [-- GRADE OPTIONS]``. Prints
figures only.

The class is built at run time in a temporary folder from the forms of ``tests/ros_class.py``
(the NumPy server with a module-level handler, the class-based one, the one reading a pickle,
the one relying on Python 2's leaking comprehension variable, the slow sympy one, and the
classic mistakes), one repository each. Each server but the sympy one is made to cost a given
CPU time per pose before it answers (a busy loop on the thread's CPU clock, as sympy's
``subs``/``evalf`` cost CPU), from :data:`COSTS`: 0.02 to 1.6 s a pose, median 0.06 s, as the
real sample's servers took on one request of 15 poses.

Printed: the wall time and the CPU time of the ``grade`` command and the processes it waited
for (a jailed server's own CPU is counted by its jail: summed last), the load before and after,
and each student's
form, cost per pose, verdict, time (from its grading process's start), its server's CPU time
(the jail's count), the cases tried of those planned and the cycles run.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import ros_class  # tests/ros_class.py: the test class's forms

#: CPU time per pose of each student [s]: 16 at 0.02-0.06 s, 14 at 0.08-1.6 s (median 0.06).
COSTS = (
    *(0.02,) * 4,
    *(0.03,) * 4,
    *(0.04,) * 3,
    *(0.05,) * 3,
    *(0.06,) * 2,
    0.08,
    0.1,
    0.12,
    0.15,
    0.2,
    0.3,
    0.4,
    0.6,
    0.8,
    1.0,
    1.0,
    1.2,
    1.6,
    1.6,
)
#: The forms, in turn (ros_class's students); the slow sympy one is put at the 1.0 s slots.
FORMS = ("alice", "bob", "carol", "oscar", "frank", "grace", "heidi", "mallory", "erin", "ivan")
SYMPY = "dave"

#: Appended before the script's ``if __name__`` line: its handler (module-level, or the
#: class-based server's method) costs COST seconds of CPU for each pose it reads, as it reads
#: it (a handler that raises on a pose has paid for the poses before it only).
SLOW = """
import time as bench_time
class BenchPoses(object):
    def __init__(self, poses):
        self.poses, self.read = poses, set()
    def __len__(self):
        return len(self.poses)
    def __getitem__(self, i):
        if i not in self.read:
            self.read.add(i)
            t0 = bench_time.thread_time()
            while bench_time.thread_time() - t0 < COST:
                pass
        return self.poses[i]
    def __iter__(self):
        for i in range(len(self.poses)):
            yield self[i]
def bench_slow(handler):
    def slow(*args):
        req = args[-1]
        poses = req.poses
        req.poses = BenchPoses(poses)
        try:
            return handler(*args)
        finally:
            req.poses = poses
    return slow
if 'KukaIK' in globals():
    KukaIK.handle_calculate_IK = bench_slow(KukaIK.handle_calculate_IK)
else:
    handle_calculate_IK = bench_slow(handle_calculate_IK)

"""


def build(folder: Path, students: int) -> list[tuple[str, str, float]]:
    """Write the class into ``folder``; returns (name, form, cost per pose) of each student."""
    made = []
    with tempfile.TemporaryDirectory() as stage:
        ros_class.write_class(Path(stage), (*FORMS, SYMPY))
        for i, cost in enumerate(COSTS[:students]):
            form = SYMPY if cost == 1.0 else FORMS[i % len(FORMS)]
            name = f"s{i:02d}_{form}"
            shutil.copytree(Path(stage) / form, folder / name)
            script = folder / name / "kuka_arm" / "scripts" / "IK_server.py"
            if form != SYMPY:
                head, main, tail = script.read_text().rpartition('if __name__ == "__main__":')
                assert main, f"{form}: no __main__ block"
                script.write_text(head + f"COST = {cost}\n" + SLOW + main + tail)
            made.append((name, form, cost))
    return made


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--students", type=int, default=len(COSTS), help="at most 30")
    parser.add_argument(
        "--keep", type=Path, help="build the class here and keep it (and the report)"
    )
    parser.add_argument("grade", nargs="*", help="more grade options, after --")
    args = parser.parse_args(argv)
    if not 1 <= args.students <= len(COSTS):
        parser.error(f"--students must be 1-{len(COSTS)}")
    with tempfile.TemporaryDirectory() as tmp:
        folder = (args.keep or Path(tmp)) / "class"
        folder.mkdir(parents=True, exist_ok=True)
        made = build(folder, args.students)
        report = Path(tmp) / "grade.json"
        cmd = [sys.executable, "-m", "kr210_sim", "grade", str(folder), "--report", str(report)]
        cmd += args.grade
        costs = sorted(c for *_, c in made)
        print(f"class: {len(made)} students, {costs[0]}-{costs[-1]} s of CPU a pose (median "
              f"{costs[len(costs) // 2]} s; the sympy server's own)")  # fmt: skip
        print(f"load before: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
        print(f"command: {' '.join(cmd[1:])}")
        t0 = time.perf_counter()
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
        wall = time.perf_counter() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
        print(f"load after: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
        print(f"wall {wall / 60:.1f} min ({wall:.0f} s), CPU {cpu / 60:.1f} min ({cpu:.0f} s), "
              f"grade exit {proc.returncode}")  # fmt: skip
        if args.keep and report.exists():
            shutil.copy2(report, args.keep / "grade.json")
        if not report.exists():
            print(proc.stdout[-2000:], proc.stderr[-2000:], sep="\n")
            return 1
        data = json.loads(report.read_text())
    by = {s["name"]: s for s in data["students"]}
    print(f"{'student':<16}{'cost s':>7}  {'verdict':<8}{'time s':>7}{'cpu s':>7}{'cases':>11}"
          f"{'cycles':>8}")  # fmt: skip
    for name, _form, cost in made:
        s = by[name]
        ik, run = s.get("ik_check") or {}, s.get("run") or {}
        cases = f"{ik.get('cases', '-')}/{ik.get('cases_total', '-')}" if ik else "-"
        cycles = f"{run.get('cycles_run', '-')}/{run.get('cycles', '-')}" if run else "-"
        took = (s.get("wall_time_s") or {}).get("total", float("nan"))
        cpu_s = (s.get("jail") or {}).get("cpu_s", float("nan"))
        print(f"{name:<16}{cost:>7.2f}  {s['verdict']:<8}{took:>7.1f}{cpu_s:>7.1f}{cases:>11}"
              f"{cycles:>8}")  # fmt: skip
    verdicts: dict[str, int] = {}
    for s in data["students"]:
        verdicts[s["verdict"]] = verdicts.get(s["verdict"], 0) + 1
    print(f"verdicts: {', '.join(f'{n} {v}' for v, n in sorted(verdicts.items()))}")
    jailed = sum((s.get("jail") or {}).get("cpu_s", 0.0) for s in data["students"])
    print(f"the students' servers' CPU, the jails' count: {jailed / 60:.1f} min ({jailed:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
