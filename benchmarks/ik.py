"""Kinematics speed: single-pose inverse/nearest/forward in microseconds, batched throughput.

Run: ``python benchmarks/ik.py``. Prints figures only (medians of repeats); no assertions.
"""

from __future__ import annotations

import statistics
import time

import numpy as np

from kr210_sim.robot import kinematics as kin


def per_call_us(fn, args_list, repeats: int = 5) -> float:  # type: ignore[no-untyped-def]
    """Median over ``repeats`` of the mean time per call [us]."""
    runs = []
    for _ in range(repeats):
        t = time.perf_counter()
        for args in args_list:
            fn(*args)
        runs.append((time.perf_counter() - t) / len(args_list) * 1e6)
    return statistics.median(runs)


def per_second(fn, arg, n: int, repeats: int = 5) -> float:  # type: ignore[no-untyped-def]
    """Median throughput [items/s] of one batched call over ``n`` items."""
    fn(arg[: min(n, 10_000)])  # warm up (thread pool, caches)
    runs = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn(arg)
        runs.append(n / (time.perf_counter() - t))
    return statistics.median(runs)


def main() -> None:
    g = kin.committed().geometry
    rng = np.random.default_rng(0)
    n = 200_000
    q = rng.uniform(g.lower, g.upper, size=(n, 6))
    T = kin.forward(q)
    single = [(T[i],) for i in range(2000)]
    near = [(T[i], q[i]) for i in range(2000)]
    fwd = [(q[i],) for i in range(2000)]
    print(f"inverse  single pose : {per_call_us(kin.inverse, single):8.1f} us (all branches)")
    print(f"nearest  single pose : {per_call_us(kin.nearest, near):8.1f} us")
    print(f"forward  single pose : {per_call_us(kin.forward, fwd):8.1f} us")
    print(f"inverse  batch {n:,}  : {per_second(kin.inverse, T, n):12,.0f} poses/s (8 branches)")
    print(f"forward  batch {n:,}  : {per_second(kin.forward, q, n):12,.0f} poses/s")


if __name__ == "__main__":
    main()
