"""SIGTERM and SIGINT on a running ``evaluate`` (local worker processes), in a real process:
the report of the finished episodes, exit 143 or 130, no traceback, no worker left behind."""

from __future__ import annotations

import json
import os
import signal
import subprocess
from pathlib import Path

import pytest
from evaluate_procs import (
    EVALUATE,
    cmdline,
    descendants,
    evaluate_process,
    left_behind,
    record_count,
    wait_for_records,
)

pytestmark = pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="needs Linux /proc")


@pytest.mark.slow
@pytest.mark.parametrize(
    ("sig", "to_group", "code"),
    [
        (signal.SIGTERM, False, 143),  # `kill PID`
        (signal.SIGTERM, True, 143),  # a service manager stopping the process group
        (signal.SIGINT, True, 130),  # Ctrl-C on a terminal reaches the whole group
    ],
    ids=["sigterm-driver", "sigterm-group", "sigint-group"],
)
def test_a_signal_writes_the_report_and_stops_every_worker(
    tmp_path: Path, sig: signal.Signals, to_group: bool, code: int
) -> None:
    report = tmp_path / "e.json"
    argv = ["--episodes", "200", "--workers", "2", "--report", str(report)]
    with evaluate_process(argv, start_new_session=True) as proc:
        wait_for_records(tmp_path / "e.episodes.jsonl", 3)
        workers = descendants(proc.pid)
        assert len(workers) >= 2
        if to_group:
            os.killpg(proc.pid, sig)
        else:
            proc.send_signal(sig)
        out, err = proc.communicate(timeout=60)
    assert proc.returncode == code, err
    for bad in ("Traceback", "BrokenPipe", "leaked", "resource_tracker"):
        assert bad not in err
    assert f"interrupted ({sig.name}) after" in err
    data = json.loads(report.read_text())
    assert data["interrupted"] is True
    done = record_count(tmp_path / "e.episodes.jsonl")
    assert 3 <= data["summary"]["episodes"] == done < 200
    assert "(interrupted)" in out
    assert left_behind(workers) == []


@pytest.mark.slow
def test_a_local_worker_killed_is_a_one_line_error_and_resume_finishes(tmp_path: Path) -> None:
    report = tmp_path / "e.json"
    argv = ["--episodes", "8", "--workers", "2"]
    argv += ["--seed", "7", "--min-success", "0", "--report", str(report)]
    with evaluate_process(argv) as proc:
        wait_for_records(tmp_path / "e.episodes.jsonl", 1)
        workers = [p for p in descendants(proc.pid) if "spawn_main" in cmdline(p)]
        os.kill(workers[0], signal.SIGKILL)
        _, err = proc.communicate(timeout=60)
    assert proc.returncode == 2, err
    assert err.count("\n") - err.count("evaluate [") == 1 and "Traceback" not in err
    assert "a worker process died running episode" in err and "--resume" in err
    kept = record_count(tmp_path / "e.episodes.jsonl")
    resumed = subprocess.run(
        [*EVALUATE, *argv, "--resume"], capture_output=True, text=True, timeout=120
    )
    assert resumed.returncode == 0, resumed.stderr
    data = json.loads(report.read_text())
    assert data["wall_execution"]["resumed_episodes"] == kept >= 1
    assert data["summary"]["episodes"] == record_count(tmp_path / "e.episodes.jsonl") == 8
