"""What a noisy student costs an honest slow neighbour graded beside it (issue 40 item 5).

Run: ``python benchmarks/noisy_neighbour.py [--cost S] [--noise N] [--pace S] [--repeat N]
[-- GRADE OPTIONS]``. Prints figures only. Each sitting grades two classes of two students with
two workers, at the defaults:

* ``quiet``: the honest slow neighbour beside a correct student (``examples/ik_dh.py``);
* ``noisy``: the same neighbour beside a noisy one, ``examples/ik_dh.py`` with, from its import on,
  ``--noise`` processes per core spinning and a thread flooding its standard output.

The neighbour is ``tests/ros_class.py``'s slow sympy server (``dave``), or with ``--cost`` its
NumPy server made to cost that much CPU time per pose (a busy loop on the thread's CPU clock, as
``benchmarks/grade_ros.py`` does). ``--pace`` makes the other student (in both classes) sleep
that long per pose, so that its grading, and its noise, last as long as the neighbour's (a
correct student is done in some 20 s, the neighbour takes its whole ``--timeout``). ``--repeat``
runs more sittings, the two classes in turn (quiet first, then noisy first), as the machine's
load drifts. Printed per class: the wall time, and per student the verdict, the ik-check cases
tried of those planned, the cycles run, its grading's wall time, its own time (what
``--timeout`` counts), the time its jail was held off the CPU by other processes (not counted;
``nan`` from a grader that does not count it) and its jail's CPU time. The figure to read is
the neighbour's cases and cycles in ``noisy`` beside those in ``quiet`` of the same sitting (the
summary's last columns: noisy over quiet).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))
sys.path.insert(0, str(HERE))

import grade_ros  # noqa: E402  benchmarks/grade_ros.py: the slowing of a server
import ros_class  # noqa: E402  tests/ros_class.py: the test class's forms

EXAMPLE = HERE.parent / "examples" / "ik_dh.py"

#: Put before the example's code: ``NOISE`` spinning processes per core and an output flood.
NOISE = """
import os as _os, sys as _sys, threading as _threading

def _spin():
    while True:
        pass

for _ in range(NOISE * (_os.cpu_count() or 1)):
    if _os.fork() == 0:
        _spin()

def _flood():
    line = "noise " * 20 + "\\n"
    while True:
        _sys.stdout.write(line)

_threading.Thread(target=_flood, daemon=True).start()
"""


#: Put before the example's code with ``--pace``: its ``solve`` sleeps ``PACE`` s first.
PACED = """
import time as _time

def _paced(solve):
    def paced(T, q_ref):
        _time.sleep(PACE)
        return solve(T, q_ref)
    return paced
"""


def build(folder: Path, noisy: bool, cost: float | None, noise: int, pace: float = 0.0) -> None:
    """Write the class: the neighbour (``neighbour``) and the quiet or noisy one (``other.py``),
    its ``solve`` sleeping ``pace`` s a pose."""
    folder.mkdir(parents=True)
    with tempfile.TemporaryDirectory() as stage:
        form = grade_ros.SYMPY if cost is None else "alice"
        ros_class.write_class(Path(stage), (form,))
        shutil.copytree(Path(stage) / form, folder / "neighbour")
    if cost is not None:
        script = folder / "neighbour" / "kuka_arm" / "scripts" / "IK_server.py"
        head, main, tail = script.read_text().rpartition('if __name__ == "__main__":')
        script.write_text(head + f"COST = {cost}\n" + grade_ros.SLOW + main + tail)
    example = EXAMPLE.read_text().replace("from __future__ import annotations\n", "")
    text = (f"NOISE = {noise}\n" + NOISE if noisy else "") + example
    if pace:
        text = f"PACE = {pace}\n" + PACED + text + "\nsolve = _paced(solve)\n"
    (folder / "other.py").write_text(text)


def grade(folder: Path, extra: list[str]) -> tuple[float, dict[str, dict[str, object]]]:
    """Grade ``folder`` with two workers: the wall time [s] and the students' records."""
    report = folder.parent / f"{folder.name}.json"
    cmd = [sys.executable, "-m", "kr210_sim", "grade", str(folder), "--workers", "2"]
    cmd += ["--report", str(report), *extra]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - t0
    if not report.exists():
        print(proc.stdout[-2000:], proc.stderr[-2000:], sep="\n")
        raise SystemExit(1)
    data = json.loads(report.read_text())
    return wall, {s["name"]: s for s in data["students"]}


def figures(s: dict[str, object]) -> tuple[int, int]:
    """A student's ik-check cases tried and cycles run."""
    ik = s.get("ik_check") or {}
    run = s.get("run") or {}
    assert isinstance(ik, dict) and isinstance(run, dict)
    return int(ik.get("cases", 0)), int(run.get("cycles_run", 0))


def row(name: str, s: dict[str, object]) -> str:
    """One student's figures."""
    ik = s.get("ik_check") or {}
    run = s.get("run") or {}
    assert isinstance(ik, dict) and isinstance(run, dict)
    cases = f"{ik.get('cases', '-')}/{ik.get('cases_total', '-')}" if ik else "-"
    cycles = f"{run.get('cycles_run', '-')}/{run.get('cycles', '-')}" if run else "-"
    wall = s.get("wall_time_s") or {}
    jail = s.get("jail") or {}
    assert isinstance(wall, dict) and isinstance(jail, dict)
    took, cpu = wall.get("total", float("nan")), jail.get("cpu_s", float("nan"))
    own = wall.get("student") or float("nan")
    held = wall.get("held_off_cpu", float("nan"))
    return (
        f"{name:<12}{s['verdict']!s:<9}{cases:>11}{cycles:>8}{took:>8.1f}{own:>8.1f}{held:>8.1f}"
        f"{cpu:>8.1f}"
    )


def sitting(n: int, label: str, wall: float, by: dict[str, dict[str, object]]) -> None:
    """Print one class's figures."""
    load = " ".join(f"{v:.2f}" for v in os.getloadavg())
    print(f"\nsitting {n}, {label}: wall {wall:.0f} s, load {load}")
    print(f"{'student':<12}{'verdict':<9}{'cases':>11}{'cycles':>8}{'time s':>8}{'own s':>8}"
          f"{'held s':>8}{'cpu s':>8}")  # fmt: skip
    for name in ("neighbour", "other"):
        print(row(name, by[name]))
        if by[name]["verdict"] != "pass":
            print(f"  {name}: {by[name]['detail']}")
    out = (by["other"].get("output") or {}).get("bytes", 0)  # type: ignore[union-attr]
    print(f"other's output: {out / 2**20:.0f} MB")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cost", type=float, help="the neighbour: NumPy at this CPU s a pose")
    parser.add_argument("--noise", type=int, default=4, help="spinning processes per core")
    parser.add_argument("--pace", type=float, default=0.0, help="the other: sleep s a pose")
    parser.add_argument("--repeat", type=int, default=1, help="sittings (default 1)")
    parser.add_argument("grade", nargs="*", help="more grade options, after --")
    args = parser.parse_args(argv)
    who = "the sympy server" if args.cost is None else f"NumPy at {args.cost} s a pose"
    paced = f"; the other sleeps {args.pace:g} s a pose" if args.pace else ""
    print(f"neighbour: {who}; noise: {args.noise} processes a core and an output flood{paced}")
    print(f"cores: {os.cpu_count()}, load before: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    got: list[dict[str, tuple[int, int]]] = []
    order = [("quiet", False), ("noisy", True)]
    with tempfile.TemporaryDirectory() as tmp:
        for n in range(args.repeat):
            got.append({})
            for label, noisy in order if n % 2 == 0 else order[::-1]:
                folder = Path(tmp) / f"{label}{n}"
                build(folder, noisy, args.cost, args.noise, args.pace)
                wall, by = grade(folder, args.grade)
                sitting(n + 1, label, wall, by)
                got[-1][label] = figures(by["neighbour"])
    print("\nthe neighbour's cases and cycles: quiet | noisy | noisy over quiet")
    for n, g in enumerate(got):
        (qc, qy), (nc, ny) = g["quiet"], g["noisy"]
        ratio = f"{nc / max(qc, 1):.2f} {ny / max(qy, 1):.2f}"
        print(f"sitting {n + 1}: {qc} {qy} | {nc} {ny} | {ratio}")
    print(f"\nload after: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
