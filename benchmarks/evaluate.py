"""The evaluation's throughput: local processes against Ray, Ray across two nodes, and memory.

Run: ``python benchmarks/evaluate.py [--episodes N] [--workers W]`` prints, for the same
randomised episodes:

- episodes/s with the local backend on W processes and with Ray started here on W CPUs (wall
  time of the whole evaluation, start-up included), and their ratio;
- episodes/s on a Ray cluster of one node (1 CPU) and of two nodes (1 CPU each) on 127.0.0.1,
  and the speed-up (the nodes share this machine's cores).

``python benchmarks/evaluate.py --rss N`` runs N episodes with the local backend (streaming to a
temporary episodes file) and prints the driver's and the largest worker's maximum resident set.
Prints figures only; Ray parts are skipped when Ray is not installed.
"""

from __future__ import annotations

import argparse
import os
import resource
import secrets
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from kr210_sim.eval.evaluate import EvalConfig, evaluate


class _Watch(threading.Thread):
    """Notes when the first record reaches the episodes file (the end of start-up)."""

    def __init__(self, path: Path) -> None:
        super().__init__(daemon=True)
        self.path = path
        self.first: float | None = None
        self.stop = threading.Event()

    def run(self) -> None:
        while not self.stop.wait(0.02):
            try:
                if self.path.read_text().count("\n") >= 2:  # the header and a record
                    self.first = time.perf_counter()
                    return
            except OSError:
                continue


def _run(config: EvalConfig) -> tuple[float, float, dict[str, Any]]:
    """Wall time of the whole evaluation [s], of the part after the first episode [s]."""
    with tempfile.TemporaryDirectory() as tmp:
        watch = _Watch(Path(tmp) / "e.episodes.jsonl")
        watch.start()
        t = time.perf_counter()
        outcome = evaluate(config, report=Path(tmp) / "e.json")
        end = time.perf_counter()
        watch.stop.set()
        watch.join()
    summary = outcome.report["summary"]
    assert summary["episodes"] == config.episodes, "the evaluation did not finish"
    steady = end - (watch.first or t)
    return end - t, steady, outcome.report["wall_execution"]


def _line(name: str, episodes: int, wall: float, steady: float) -> tuple[float, float]:
    rate, rate_steady = episodes / wall, (episodes - 1) / steady
    print(
        f"  {name:30s} {wall:6.1f} s  {rate:5.2f} episodes/s"
        f"  (after the first episode: {rate_steady:5.2f} episodes/s)"
    )
    return rate, rate_steady


def _ratio(name: str, a: tuple[float, float], b: tuple[float, float]) -> None:
    print(f"  {name}: {a[0] / b[0]:.2f}x (after the first episode {a[1] / b[1]:.2f}x)")


def throughput(episodes: int, workers: int) -> None:
    """Local against Ray with the same workers, then Ray on one node and on two."""
    common = {"episodes": episodes, "seed": 0, "randomize": True, "workers": workers}
    print(f"{episodes} randomised episodes, {workers} workers, {os.cpu_count()} cores")
    local = _line("local processes", episodes, *_run(EvalConfig(**common))[:2])
    try:
        import ray  # noqa: F401
    except ImportError:
        print("  (Ray not installed: pip install -e '.[ray]')")
        return
    on_ray = _line("Ray started here", episodes, *_run(EvalConfig(**common, backend="ray"))[:2])
    _ratio("Ray / local", on_ray, local)

    from ray._private import ray_constants
    from ray._private.authentication_test_utils import reset_auth_token_state
    from ray.cluster_utils import Cluster

    os.environ["RAY_AUTH_MODE"] = "token"
    os.environ["RAY_AUTH_TOKEN"] = secrets.token_hex(32)
    reset_auth_token_state()
    ray_constants.ENABLE_RAY_CLUSTER = False  # keep a one-machine cluster on 127.0.0.1
    node = {"num_cpus": 1, "node_ip_address": "127.0.0.1"}
    head = {**node, "include_dashboard": False, "_system_config": {"worker_niceness": 0}}
    cluster = Cluster(initialize_head=True, head_node_args=head)
    try:
        one_node = {**common, "workers": 1, "backend": "ray", "address": cluster.address}
        one = _line("Ray cluster, 1 node x 1 CPU", episodes, *_run(EvalConfig(**one_node))[:2])
        cluster.add_node(**node)
        wall, steady, ex = _run(EvalConfig(**{**one_node, "workers": 2}))
        two = _line(f"Ray cluster, {ex['nodes']} nodes x 1 CPU", episodes, wall, steady)
        _ratio("two nodes / one node", two, one)
    finally:
        cluster.shutdown()


def memory(episodes: int, workers: int) -> None:
    """Maximum resident set of the driver and of the largest worker for ``episodes``."""
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    config = EvalConfig(episodes=episodes, seed=0, randomize=True, workers=workers)
    wall = _run(config)[0]
    driver = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    worker = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    print(f"{episodes} randomised episodes on {workers} local workers: {wall:.0f} s")
    print(f"  driver max RSS   {driver:7.1f} MB (before the evaluation {before:.1f} MB)")
    print(f"  worker max RSS   {worker:7.1f} MB (largest worker)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--rss", type=int, default=None, metavar="N", help="measure memory")
    args = parser.parse_args()
    if args.rss is not None:
        memory(args.rss, args.workers)
    else:
        throughput(args.episodes, args.workers)


if __name__ == "__main__":
    main()
