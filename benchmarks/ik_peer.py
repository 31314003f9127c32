"""Our closed-form IK against the Rust peer ``py-opw-kinematics`` 1.3.0, side by side.

Run: ``python benchmarks/ik_peer.py [--poses N] [--calls N] [--batch N] [--repeats N]``. The
peer is a benchmark-only install, not a dependency:
``.venv/bin/pip install py-opw-kinematics==1.3.0``.

The peer is configured with the KR210's OPW parameters, derived from our URDF geometry
(``Kinematics.geometry``): a1 = joint_2's forward offset, a2 = the forearm's drop below joint_3
(-a3z), b = 0, c1 = joint_2's height, c2 = link_2, c3 = joint_3 to the wrist centre along the
forearm, c4 = wrist centre to gripper_link, a -90 deg offset on joint 3 (OPW's zero has the
forearm upright, ours level). Its tool frame has z along our gripper_link's x: poses are handed
to it as ``T_base_gripper @ Ry(90 deg)``, converted before any clock runs.

1. Agreement: forward kinematics on random q, then the branch sets of both on the same poses
   (random inside the limits, wrist singular q5 = 0, wrist centre on joint 1's axis, joints at
   their limits, elbow stretched, out of reach). The peer knows no joint limits: its solutions
   are put through our rule (wrapped to (-pi, pi], shifted by 2 pi into the limits, dropped if
   outside). Every solution of both must reach the pose (to 1e-9); two sets are the same when
   each solution has one in the other with all six joints within 1e-6 rad, the same up to a
   free joint when they have the same arm branches (q2, q3, and as many distinct q5 for each):
   on joint 1's axis q1 is free, at q5 = 0 only q4 + q6 is defined.
2. Speed: one pose all branches, the solution nearest a reference q (near a solution, and
   drawn at random), a batch. Ours twice for one pose, through the same public calls
   (``kin.inverse``, ``kin.nearest``): the compiled single-pose path (``_ik_native``, what a
   ``pip install`` with a C compiler uses) and the pure-Python one (what it falls back to,
   ``KR210_SIM_PURE_IK=1``), swapped in for the measurement. The peer is called through its
   compiled ``Robot``, under the scipy wrapper (the wrapper's ``inverse`` takes a
   ``RigidTransform``: 0.7 us more a call when one is made beforehand, some 50 us when it is
   made from the 4x4 matrix). Single calls
   in CPU time of the calling thread, medians of interleaved repeats, so both sides see the
   same load.
"""

from __future__ import annotations

import argparse
import gc
import math
import statistics
import sys
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from kr210_sim.robot import ik_scalar
from kr210_sim.robot import kinematics as kin

G = kin.committed().geometry
#: Peer tool frame (z forward) in our gripper_link frame (x forward).
TOOL = np.array([[0.0, 0.0, 1.0, 0.0], [0.0, 1.0, 0.0, 0.0], [-1.0, 0.0, 0.0, 0.0], [0, 0, 0, 1.0]])
MATCH_TOL = 1e-6  # [rad]
REACH_TOL = 1e-9  # [m] and entries of R


def make_peer() -> Any:
    """The peer's compiled ``Robot`` (radians) with the KR210's OPW parameters, or None."""
    try:
        from py_opw_kinematics import KinematicModel, Robot
    except ImportError:
        return None
    model = KinematicModel(
        a1=G.a1, a2=-G.a3z, b=0.0, c1=G.d0 + G.h1, c2=G.a2, c3=G.a3x, c4=G.dg,
        offsets=(0.0, 0.0, -math.pi / 2, 0.0, 0.0, 0.0), flip_axes=(False,) * 6,
    )  # fmt: skip
    return Robot(model, degrees=False)._robot  # the compiled class under the scipy wrapper


def fit_limits(rows: np.ndarray) -> np.ndarray:
    """Our limit rule on any solutions (k, 6): wrapped to (-pi, pi], shifted by 2 pi into the
    limits where needed; the rows still outside are dropped."""
    v = np.remainder(rows + math.pi, 2 * math.pi) - math.pi
    v = np.where(v <= -math.pi, v + 2 * math.pi, v)
    v = np.where(v < G.lower - kin.LIMIT_SLACK, v + 2 * math.pi, v)
    v = np.where(v > G.upper + kin.LIMIT_SLACK, v - 2 * math.pi, v)
    ok = ((v >= G.lower - kin.LIMIT_SLACK) & (v <= G.upper + kin.LIMIT_SLACK)).all(axis=1)
    return v[ok]


def pose_sets(rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
    """Poses (k, 4, 4) by kind: random q inside the limits, and the hard cases."""
    k = max(n // 100, 200)
    q = rng.uniform(G.lower, G.upper, size=(n, 6))
    wrist = rng.uniform(G.lower, G.upper, size=(k, 6))
    wrist[:, 4] = 0.0
    # wrist centre on joint 1's axis: a1 + a2 sin q2 + L cos(q2 + q3 + phi) = 0
    axis = rng.uniform(G.lower, G.upper, size=(k, 6))
    axis[:, 1] = rng.uniform(-0.3, 0.3, size=k)
    c = -(G.a1 + G.a2 * np.sin(axis[:, 1])) / G.forearm
    axis[:, 2] = -np.arccos(c) - G.forearm_angle - axis[:, 1]
    limits = rng.uniform(G.lower, G.upper, size=(k, 6))
    for row in limits:
        j = rng.choice(6, size=2, replace=False)
        row[j] = np.where(rng.random(2) < 0.5, G.lower[j], G.upper[j])
    stretched = rng.uniform(G.lower, G.upper, size=(k, 6))
    stretched[:, 2] = -math.pi / 2 - G.forearm_angle  # forearm in line with link_2
    far = kin.forward(rng.uniform(G.lower, G.upper, size=(k, 6)))  # wrist centre 5 cm - 2 m
    u = rng.normal(size=(k, 3))  # beyond the reach from either place joint 2 can take
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    centre = np.array([0.0, 0.0, G.d0 + G.h1]) + u * (G.a1 + G.reach + rng.uniform(0.05, 2, (k, 1)))
    far[:, :3, 3] = centre + G.dg * far[:, :3, 0]
    return {
        "random q inside the limits": kin.forward(q),
        "wrist singular (q5 = 0)": kin.forward(wrist),
        "wrist centre on joint 1's axis": kin.forward(axis),
        "two joints at a limit": kin.forward(limits),
        "elbow stretched": kin.forward(stretched),
        "out of reach": far,
    }


def miss(rows: np.ndarray, T: np.ndarray) -> np.ndarray:
    """How far each solution (k, 6) puts gripper_link from ``T`` (largest entry of the 4x4)."""
    if not len(rows):
        return np.zeros(0)
    return np.abs(kin.forward(rows) - T).max(axis=(1, 2))


def reaches(rows: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Whether each solution (k, 6) puts gripper_link at ``T``."""
    return miss(rows, T) <= REACH_TOL


def classes(rows: np.ndarray) -> list[tuple[float, float, int]]:
    """Arm branches of a solution set: (q2, q3, how many distinct q5) for each distinct (q2, q3).

    What a singularity leaves determined: on joint 1's axis q1 is free (and q4, q6 with it), at
    q5 = 0 only q4 + q6 is.
    """
    out: list[tuple[float, float, list[float]]] = []
    for row in rows:
        for q2, q3, q5s in out:
            if abs(row[1] - q2) <= MATCH_TOL and abs(row[2] - q3) <= MATCH_TOL:
                if all(abs(row[4] - v) > MATCH_TOL for v in q5s):
                    q5s.append(row[4])
                break
        else:
            out.append((row[1], row[2], [row[4]]))
    return [(q2, q3, len(q5s)) for q2, q3, q5s in out]


def compare(ours: np.ndarray, peer: np.ndarray, T: np.ndarray) -> str:
    """How two solution sets of one pose agree: same / same up to a free joint / the reason."""
    if not reaches(ours, T).all():
        return "ours: a solution off the pose"
    if not reaches(peer, T).all():
        return "peer: a solution off the pose"
    if not len(ours) and not len(peer):
        return "same"
    if len(ours) and len(peer):
        exact = (np.abs(ours[:, None, :] - peer[None, :, :]) <= MATCH_TOL).all(axis=2)
        if exact.any(axis=1).all() and exact.any(axis=0).all():
            return "same"
    mine, theirs = classes(ours), classes(peer)

    def covered(a: list[tuple[float, float, int]], b: list[tuple[float, float, int]]) -> bool:
        return all(
            any(abs(x2 - y2) <= MATCH_TOL and abs(x3 - y3) <= MATCH_TOL and n <= m
                for y2, y3, m in b)
            for x2, x3, n in a
        )  # fmt: skip

    if not covered(mine, theirs):
        return "peer misses a branch"
    if not covered(theirs, mine):
        return "peer has a branch ours lacks"
    return "same up to a free joint"


def agreement(peer: Any, sets: dict[str, np.ndarray]) -> None:
    """Print, per kind of pose, how the two solution sets agree."""
    q = np.random.default_rng(9).uniform(G.lower, G.upper, size=(2000, 6))
    fk = max(
        float(np.abs(np.asarray(peer.forward(tuple(row), None)) @ np.linalg.inv(TOOL) - T).max())
        for row, T in zip(q, kin.forward(q), strict=True)
    )
    print(f"forward kinematics, 2,000 random q: largest difference {fk:.1e} (m and R entries)")
    print(f"{'poses':31s} {'n':>7s} {'ours':>7s} {'peer':>7s} {'worst miss':>17s}  agreement")
    for name, T in sets.items():
        batch = kin.inverse(T)
        tally: dict[str, int] = {}
        n_ours = n_peer = 0
        worst = [0.0, 0.0]
        for i in range(len(T)):
            ours = batch[i][~np.isnan(batch[i, :, 0])]
            raw = peer.inverse(T[i] @ TOOL, None, None)
            theirs = fit_limits(np.asarray(raw, dtype=float).reshape(-1, 6))
            n_ours, n_peer = n_ours + len(ours), n_peer + len(theirs)
            for k, rows in enumerate((ours, theirs)):
                worst[k] = max(worst[k], float(miss(rows, T[i]).max(initial=0.0)))
            verdict = compare(ours, theirs, T[i])
            tally[verdict] = tally.get(verdict, 0) + 1
        said = ", ".join(f"{v} {c:,}" for v, c in sorted(tally.items(), key=lambda kv: -kv[1]))
        counts = f"{len(T):7,d} {n_ours:7,d} {n_peer:7,d}"
        print(f"{name:31s} {counts} {worst[0]:8.0e} {worst[1]:8.0e}  {said}")
    print(
        "(ours, peer: solutions inside the limits over all the poses; worst miss: the largest"
        f" entry of |T(q) - T| over them, ours then peer; off the pose: over {REACH_TOL:.0e})"
    )


def interleaved(fns: list[Callable[[], float]], repeats: int) -> list[float]:
    """Median of each measurement, the measurements taking turns ``repeats`` times."""
    runs: list[list[float]] = [[] for _ in fns]
    gc.disable()
    try:
        for _ in range(repeats):
            for k, fn in enumerate(fns):
                runs[k].append(fn())
    finally:
        gc.enable()
    return [statistics.median(r) for r in runs]


def per_call(
    fn: Callable[..., Any], args: list[tuple[Any, ...]], pure: bool = False
) -> Callable[[], float]:
    """A measurement: mean CPU time of the calling thread per call over ``args`` [us] (both
    sides compute in the calling thread; CPU time leaves out the time other processes hold the
    core). With ``pure``, ``kin``'s single-pose functions are the pure-Python ones meanwhile."""

    def run() -> float:
        saved = kin.inverse_one, kin.nearest_one
        if pure:
            kin.inverse_one, kin.nearest_one = ik_scalar.inverse_one_py, ik_scalar.nearest_one_py
        try:
            t = time.thread_time()
            for a in args:
                fn(*a)
            return (time.thread_time() - t) / len(args) * 1e6
        finally:
            kin.inverse_one, kin.nearest_one = saved

    return run


def three_ways(
    ours: Callable[..., Any],
    ours_args: list[tuple[Any, ...]],
    theirs: Callable[..., Any],
    their_args: list[tuple[Any, ...]],
    repeats: int,
) -> list[float]:
    """Medians [us] of one call: ours compiled (as installed), ours pure Python, the peer."""
    return interleaved(
        [per_call(ours, ours_args), per_call(ours, ours_args, pure=True),
         per_call(theirs, their_args)], repeats,
    )  # fmt: skip


def per_second(fn: Callable[[], Any], n: int) -> Callable[[], float]:
    """A measurement: items per second of wall time of one call over ``n`` items (the batch
    calls may use threads)."""

    def run() -> float:
        t = time.perf_counter()
        fn()
        return n / (time.perf_counter() - t)

    return run


def speed(peer: Any, calls: int, batch: int, repeats: int) -> None:
    """Print the side-by-side table of times."""
    rng = np.random.default_rng(0)
    q = rng.uniform(G.lower, G.upper, size=(max(calls, batch), 6))
    T = kin.forward(q)
    Tp = T @ TOOL
    ref = q + rng.normal(0.0, 0.05, size=q.shape)  # a reference near one of the solutions
    ref_t = [tuple(r) for r in ref.tolist()]
    far = rng.uniform(G.lower, G.upper, size=(calls, 6))  # a reference anywhere
    far_t = [tuple(r) for r in far.tolist()]
    flat = np.ascontiguousarray(Tp[:batch].reshape(-1, 16))
    limits = list(zip(G.lower.tolist(), G.upper.tolist(), strict=True))
    kin.inverse(T[:1000])  # warm up (thread pool)
    n = range(calls)
    one = three_ways(
        kin.inverse, [(T[i],) for i in n], peer.inverse, [(Tp[i], None, None) for i in n], repeats
    )
    near = three_ways(
        kin.nearest, [(T[i], ref[i]) for i in n],
        peer.inverse, [(Tp[i], ref_t[i], None) for i in n], repeats,
    )  # fmt: skip
    anywhere = three_ways(
        kin.nearest, [(T[i], far[i]) for i in n],
        peer.inverse, [(Tp[i], far_t[i], None) for i in n], repeats,
    )  # fmt: skip
    many = interleaved(
        [
            per_second(lambda: kin.inverse(T[:batch]), batch),
            per_second(lambda: peer.reach(flat, limits, None, 1), batch),
            per_second(lambda: peer.reach(flat, limits, None, 0), batch),
            per_second(lambda: peer.batch_inverse(flat, ref_t[0], None), batch),
        ],
        max(3, repeats // 2),
    )
    if not ik_scalar.NATIVE:
        print("the compiled path is not built here (no C compiler at install, or")
        print("KR210_SIM_PURE_IK=1): its column is the pure-Python path again")
    print(f"{'call':42s} {'compiled':>14s} {'pure Python':>14s} {'peer':>14s}  peer / ours, each")
    for label, (compiled, pure, theirs) in (
        ("one pose, all branches", one),
        ("nearest to a reference q (near a solution)", near),
        ("nearest to a reference q drawn at random", anywhere),
    ):
        print(
            f"{label:42s} {compiled:11.2f} us {pure:11.2f} us {theirs:11.2f} us"
            f"  {theirs / compiled:.2f}, {theirs / pure:.2f}"
        )
    print(f"{'':42s} {'ours':>14s} {'':>14s} {'peer':>14s}  ours / peer")
    for label, peer_rate in (
        ("peer: reach, 1 thread", many[1]),
        ("peer: reach, all cores", many[2]),
        ("peer: batch_inverse", many[3]),
    ):
        print(
            f"{f'batch of {batch:,} ({label})':42s} {many[0] / 1e3:10,.0f} k/s {'':>14s}"
            f" {peer_rate / 1e3:10,.0f} k/s  {many[0] / peer_rate:.2f}"
        )
    print(
        "ours: inverse(T), nearest(T, q_ref), inverse(poses) (every branch inside the limits);"
        " one pose compiled (when built) and in pure Python, the batch in numpy.\n"
        "peer: Robot.inverse(T), inverse(T, q_ref) (every solution, nearest first),"
        " reach(poses, limits) (every branch, with its Jacobian's smallest singular value),"
        " batch_inverse(poses, q0) (one solution a pose, each nearest the one before).\n"
        "single calls: CPU time of the calling thread, median of interleaved repeats;"
        " batches: wall time."
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=100_000, help="random poses compared")
    parser.add_argument("--calls", type=int, default=2000, help="single-pose calls per repeat")
    parser.add_argument("--batch", type=int, default=200_000, help="poses in the batch call")
    parser.add_argument("--repeats", type=int, default=9, help="interleaved repeats")
    args = parser.parse_args(argv)
    if min(args.poses, args.calls, args.batch, args.repeats) < 1:
        print("ik_peer: --poses, --calls, --batch and --repeats must be >= 1", file=sys.stderr)
        return 2
    peer = make_peer()
    if peer is None:
        print(
            "ik_peer: the peer is not installed: .venv/bin/pip install py-opw-kinematics==1.3.0",
            file=sys.stderr,
        )
        return 2
    agreement(peer, pose_sets(np.random.default_rng(1), args.poses))
    print()
    speed(peer, args.calls, args.batch, args.repeats)
    return 0


if __name__ == "__main__":
    sys.exit(main())
