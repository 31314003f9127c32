"""Bring-your-own-IK speed: ik-check wall time and time per call, and ten cycles with --ik.

Run: ``python benchmarks/ik_check.py [--cases N]``. Prints figures only. Checks our IK
(``kr210_sim.robot.kinematics:nearest``) and the worked example (``examples/ik_dh.py:solve``) on the
fixed cases plus N random ones (the case set is built once and timed separately), then runs
``run --cycles 10`` planned with each, and with the worked example minus the 0.054 m offset.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from kr210_sim.grading.ikcheck import check, fixed_cases, random_cases, summarise
from kr210_sim.robot.kinematics import committed
from kr210_sim.sandbox.user_ik import load_ik
from kr210_sim.sim.runner import RunConfig, Runner

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "ik_dh.py"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--cases", type=int, default=1000)
    args = parser.parse_args()

    tmp = Path(tempfile.mkdtemp())
    broken = tmp / "ik_no_offset.py"
    broken.write_text(EXAMPLE.read_text().replace("\nA3 = -0.054", "\nA3 = 0.0"))
    specs = {
        "ours": "kr210_sim.robot.kinematics:nearest",
        "worked": f"{EXAMPLE}:solve",
        "no offset": f"{broken}:solve",
    }
    t = time.perf_counter()
    k = committed()
    cases = fixed_cases(k) + random_cases(k, args.cases, 0)
    print(f"building {len(cases)} cases: {time.perf_counter() - t:6.2f} s")
    for name, spec in specs.items():
        ik = load_ik(spec)
        t = time.perf_counter()
        records = check(k, ik, cases)
        wall = time.perf_counter() - t
        s = summarise(records)
        w = s["wall_time_s"]
        pos, ori = s["max_position_error_m"] or 0.0, s["max_orientation_error_rad"] or 0.0
        print(
            f"ik-check {name:<9}: {wall:6.2f} s for {len(cases)} cases, per call mean "
            f"{1e6 * w['per_call_mean']:7.1f} us, max {1e6 * w['per_call_max']:8.1f} us; "
            f"passed {s['passed']}/{s['cases']}, worst {1000 * pos:.3g} mm / {1000 * ori:.3g} mrad"
        )
    for name, spec in (("default", None), *specs.items()):
        runner = Runner(RunConfig(), ik=load_ik(spec) if spec else None)
        t = time.perf_counter()
        results = [runner.run_cycle(i, runner.slot_for_cycle()) for i in range(1, 11)]
        wall = time.perf_counter() - t
        ok = sum(r.success for r in results)
        extra = ""
        if runner.planner.user_ik is not None:
            st = runner.planner.user_ik.stats
            extra = f", {st.calls} IK calls, {1e6 * st.mean:.1f} us mean, {1e6 * st.max:.1f} us max"
        reasons = sorted({r.reason for r in results if r.reason})
        print(f"run 10   {name:<9}: {wall:6.2f} s, {ok}/10 succeeded {reasons or ''}{extra}")


if __name__ == "__main__":
    main()
