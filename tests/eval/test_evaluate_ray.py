"""``evaluate --backend ray`` on a real two-node Ray cluster on 127.0.0.1: the same report as
the local backend, byte for byte; a worker process killed mid-run loses and double-counts
nothing; SIGTERM on a driver that started its own Ray leaves no process behind.

Select with ``-m ray``; skipped when Ray is not installed (``pip install -e '.[ray]'``).
"""

from __future__ import annotations

import json
import os
import secrets
import signal
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from evaluate_procs import (
    cmdline,
    descendants,
    evaluate_process,
    left_behind,
    record_count,
    wait_for_records,
)

from kr210_sim.eval.evaluate import EvalConfig, evaluate
from kr210_sim.score.report import strip_wall

ray = pytest.importorskip("ray", reason="needs the [ray] extra: pip install -e '.[ray]'")
pytestmark = [pytest.mark.ray, pytest.mark.slow]

#: The evaluation every test compares: few episodes, randomised cells.
CONFIG = {"episodes": 12, "seed": 4, "randomize": True}
#: Episodes of the evaluations stopped by a signal: on two workers, tasks of 6 episodes, so the
#: first records come after 6 (with 200, tasks of 16: 5-10 s more a test) and 42 are still to
#: run when the signal comes.
STOPPED = "48"


def _text(report: Path) -> str:
    """The report file without its machine-dependent fields, as the writer lays it out."""
    return json.dumps(strip_wall(json.loads(report.read_text())), indent=2, sort_keys=True)


@pytest.fixture(scope="module")
def cluster() -> Iterator[Any]:
    """A head and a second worker node, one CPU each, advertising 127.0.0.1; stopped by pid.

    One per test process (``make test`` runs two: each that gets a cluster test starts one;
    pytest-xdist's ``xdist_group`` does not group tests under pytest 9.2).
    """
    from ray._private import ray_constants
    from ray._private.authentication_test_utils import reset_auth_token_state
    from ray.cluster_utils import Cluster

    patch = pytest.MonkeyPatch()
    # Ray's token authentication with a token of this test's own (set the same way for the
    # head, the worker node and the driver: they all read this process's environment).
    patch.setenv("RAY_AUTH_MODE", "token")
    patch.setenv("RAY_AUTH_TOKEN", secrets.token_hex(32))
    reset_auth_token_state()  # this process read its settings when it imported Ray
    # Ray turns a 127.0.0.1 cluster address into the machine's interface address before it
    # connects; a single-machine cluster keeps it on loopback.
    patch.setattr(ray_constants, "ENABLE_RAY_CLUSTER", False)
    before = descendants(os.getpid())
    node = {"num_cpus": 1, "node_ip_address": "127.0.0.1"}
    c = Cluster(initialize_head=True, head_node_args={**node, "include_dashboard": False})
    try:
        c.add_node(**node)
        started = descendants(os.getpid()) - before
        yield c
    finally:
        c.shutdown()  # kills every process of both nodes by pid
        patch.undo()
        reset_auth_token_state()
    assert left_behind(started) == []


@pytest.fixture(scope="module")
def local_report(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("local") / "e.json"
    evaluate(EvalConfig(**CONFIG, workers=1), report=path)
    return path


def test_the_cluster_gives_the_local_report_byte_for_byte(
    cluster: Any, local_report: Path, tmp_path: Path
) -> None:
    path = tmp_path / "e.json"
    outcome = evaluate(EvalConfig(**CONFIG, backend="ray", address=cluster.address), report=path)
    assert _text(path) == _text(local_report)
    ex = outcome.report["wall_execution"]
    assert (ex["backend"], ex["nodes"], ex["cpus"], ex["workers"]) == ("ray", 2, 2, 2)
    assert json.loads(local_report.read_text())["wall_execution"]["backend"] == "local"


def test_a_worker_killed_mid_run_loses_and_double_counts_nothing(
    cluster: Any, local_report: Path, tmp_path: Path
) -> None:
    path = tmp_path / "e.json"
    log = tmp_path / "e.episodes.jsonl"
    killed: list[str] = []

    def kill_a_busy_worker() -> None:
        wait_for_records(log, 2)
        deadline = time.monotonic() + 60
        while not killed and time.monotonic() < deadline:
            for pid in descendants(os.getpid()):
                if cmdline(pid).startswith("ray::run_chunk"):  # a worker inside a task
                    os.kill(pid, signal.SIGKILL)
                    killed.append(cmdline(pid) or str(pid))
                    return
            time.sleep(0.05)

    killer = threading.Thread(target=kill_a_busy_worker, daemon=True)
    killer.start()
    outcome = evaluate(EvalConfig(**CONFIG, backend="ray", address=cluster.address), report=path)
    killer.join(timeout=5)
    assert killed, "no Ray worker was caught running a task"
    assert not outcome.interrupted
    records = [json.loads(line) for line in log.read_text().splitlines()[1:]]
    assert sorted(r["episode"] for r in records) == list(range(CONFIG["episodes"]))
    assert _text(path) == _text(local_report)


def _running_tasks() -> list[int]:
    """Ray worker processes of this test's cluster that are inside an episode chunk."""
    return [p for p in descendants(os.getpid()) if cmdline(p).startswith("ray::run_chunk")]


def test_sigterm_on_a_driver_leaves_no_task_running_on_the_cluster(
    cluster: Any, tmp_path: Path
) -> None:
    report = tmp_path / "e.json"
    argv = ["--backend", "ray", "--address", cluster.address, "--episodes", STOPPED]
    # the driver runs in its own process: it reads Ray's loopback setting from the environment
    env = {**os.environ, "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER": "0"}
    with evaluate_process([*argv, "--report", str(report)], env=env) as proc:
        wait_for_records(tmp_path / "e.episodes.jsonl", 2)
        assert _running_tasks()
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=90)
    assert proc.returncode == 143, err
    assert json.loads(report.read_text())["interrupted"] is True
    deadline = time.monotonic() + 20
    while _running_tasks() and time.monotonic() < deadline:
        time.sleep(0.2)
    assert [cmdline(p) for p in _running_tasks()] == []


def test_sigterm_on_a_driver_that_started_ray_leaves_nothing_behind(tmp_path: Path) -> None:
    report = tmp_path / "e.json"
    argv = ["--backend", "ray", "--workers", "2", "--episodes", STOPPED]
    with evaluate_process([*argv, "--report", str(report)], start_new_session=True) as proc:
        wait_for_records(tmp_path / "e.episodes.jsonl", 2)
        started = descendants(proc.pid)
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=90)
    assert proc.returncode == 143, err
    assert "Traceback" not in err
    data = json.loads(report.read_text())
    assert data["interrupted"] is True
    assert data["summary"]["episodes"] == record_count(tmp_path / "e.episodes.jsonl")
    assert left_behind(started, grace=15.0) == []


def test_a_perceived_evaluation_on_the_cluster_is_the_local_one(
    cluster: Any, tmp_path: Path
) -> None:
    """`evaluate --perceive --randomize --backend ray`: the Ray workers render the sensors and
    perceive as a local worker does; the report (perception block included) is the same."""
    from kr210_sim.cell.toml import PUBLISHED_CELL

    config = {
        "episodes": 4,
        "seed": 9,
        "randomize": True,
        "perceive": True,
        "cell": PUBLISHED_CELL.parent / "cluttered.toml",
    }
    (tmp_path / "local").mkdir(), (tmp_path / "ray").mkdir()
    evaluate(EvalConfig(**config, workers=1), report=tmp_path / "local" / "e.json")
    out = evaluate(
        EvalConfig(**config, backend="ray", address=cluster.address),
        report=tmp_path / "ray" / "e.json",
    )
    assert _text(tmp_path / "ray" / "e.json") == _text(tmp_path / "local" / "e.json")
    p = out.report["summary"]["perception"]
    assert p["episodes"] == 4 and p["position_error_mm"] is not None
    assert out.report["wall_execution"]["nodes"] == 2


def test_a_users_perception_on_the_cluster_is_the_local_one(cluster: Any, tmp_path: Path) -> None:
    """`evaluate --perceive --perception SPEC --backend ray`: each Ray worker starts the user's
    function in a jail of its own and picks from it as a local worker does."""
    from kr210_sim.cell.toml import PUBLISHED_CELL

    example = Path(__file__).resolve().parents[2] / "examples" / "perception_simple.py"
    config = {
        "episodes": 2,
        "seed": 3,
        "perceive": True,
        "perception": f"{example}:perceive",
        "cell": PUBLISHED_CELL.parent / "cluttered.toml",
    }
    (tmp_path / "local").mkdir(), (tmp_path / "ray").mkdir()
    evaluate(EvalConfig(**config, workers=1), report=tmp_path / "local" / "e.json")
    out = evaluate(
        EvalConfig(**config, backend="ray", address=cluster.address),
        report=tmp_path / "ray" / "e.json",
    )
    assert _text(tmp_path / "ray" / "e.json") == _text(tmp_path / "local" / "e.json")
    assert out.report["summary"]["successes"] == 2
    assert out.report["summary"]["perception"]["recognised"] == 2
    assert out.report["config"]["perception"] == f"{example}:perceive"
