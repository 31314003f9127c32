"""Monte-Carlo evaluation: pure seeded episodes, worker-count independence, streaming, resume,
interruption, the worker cap."""

from __future__ import annotations

import json
import logging
import os
import signal
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

import kr210_sim.eval.episode as episode
from kr210_sim.cli import main
from kr210_sim.errors import ConfigError
from kr210_sim.eval.evaluate import EvalConfig, episode_seed, evaluate
from kr210_sim.eval.local_backend import LocalBackend
from kr210_sim.eval.ray_backend import INSTALL_HINT
from kr210_sim.score.report import strip_wall


def _same(a: dict[str, Any], b: dict[str, Any]) -> bool:
    return json.dumps(strip_wall(a), sort_keys=True) == json.dumps(strip_wall(b), sort_keys=True)


def _lines(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text().splitlines()[1:]]


def test_episode_seeds_are_fixed_and_distinct() -> None:
    seeds = [episode_seed(0, i) for i in range(1000)]
    assert len(set(seeds)) == 1000
    # golden values: the derivation must not change unnoticed (reports name the seeds, and
    # `run --seed <episode seed>` replays an episode). 128 bits of SeedSequence([seed, i]):
    # no duplicates in any feasible sweep (the 32-bit seeds of before, which are the low 32
    # bits of these, repeated 12 times in 300,000 episodes).
    assert seeds[:2] == [
        228566938027350531518154623208366831806,
        162545357357079157449003991920155030596,
    ]
    assert [s & 0xFFFFFFFF for s in seeds[:3]] == [2968811710, 3964924996, 3141116543]
    assert episode_seed(1, 0) != episode_seed(0, 0)
    assert all(0 <= s < 2**128 for s in seeds) and max(seeds) > 2**120


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"episodes": 0}, "episodes must be"),
        ({"workers": 0}, "workers must be"),
        ({"seed": -1}, "seed must be"),
        ({"backend": "slurm"}, "backend must be one of local, ray"),
        ({"address": "auto"}, "--address needs --backend ray"),
    ],
)
def test_config_is_checked(kwargs: dict[str, Any], message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        EvalConfig(**kwargs)


def test_same_results_whatever_the_worker_count(tmp_path: Path) -> None:
    one = evaluate(EvalConfig(episodes=6, seed=3, randomize=True, workers=1))
    two = evaluate(EvalConfig(episodes=6, seed=3, randomize=True, workers=2))
    assert _same(one.report, two.report)
    assert one.report["summary"]["successes"] == 6
    assert (
        one.report["wall_execution"]["workers"] == 1
        and two.report["wall_execution"]["workers"] == 2
    )
    assert one.report["wall_execution"]["backend"] == "local"


def test_an_obstacle_cell_planned_by_ompl_is_the_same_whatever_the_worker_count(
    tmp_path: Path,
) -> None:
    """OMPL is seeded from each move's ends and a worker's planner remembers moves across its
    episodes: neither may make an episode depend on which worker ran it, or after what."""
    from kr210_sim.cell.toml import PUBLISHED_CELL

    cell = PUBLISHED_CELL.parent / "slalom.toml"
    config = {"episodes": 4, "seed": 7, "randomize": True, "cell": cell}
    (tmp_path / "one").mkdir(), (tmp_path / "two").mkdir()
    one = evaluate(EvalConfig(**config, workers=1), report=tmp_path / "one" / "e.json")
    two = evaluate(EvalConfig(**config, workers=2), report=tmp_path / "two" / "e.json")
    assert _same(one.report, two.report)
    assert one.report["summary"]["successes"] == 4
    episodes = sorted(_lines(tmp_path / "one" / "e.episodes.jsonl"), key=lambda e: e["episode"])
    planners = [m["planner"] for e in episodes for m in e["moves"]]
    assert planners.count("ompl") >= 4  # the columns are in the way of every cycle
    # episode for episode, moves and planners included (only the measured times differ; two
    # workers write their episodes as they finish)
    two_episodes = sorted(_lines(tmp_path / "two" / "e.episodes.jsonl"), key=lambda e: e["episode"])
    assert strip_wall(episodes) == strip_wall(two_episodes)


def test_records_stream_to_the_episodes_file_and_replay_as_runs(tmp_path: Path) -> None:
    outcome = evaluate(EvalConfig(episodes=3, seed=5, randomize=True), report=tmp_path / "e.json")
    assert outcome.episodes_path == tmp_path / "e.episodes.jsonl"
    written = json.loads((tmp_path / "e.json").read_text())
    assert written == json.loads(json.dumps(outcome.report))
    assert written["episodes_file"] == "e.episodes.jsonl"
    records = sorted(_lines(tmp_path / "e.episodes.jsonl"), key=lambda r: r["episode"])
    assert [r["episode"] for r in records] == [0, 1, 2]
    assert [r["seed"] for r in records] == [episode_seed(5, i) for i in range(3)]
    # any episode replays exactly as a one-cycle run, whose cycle record is the episode record
    out = tmp_path / "replay.json"
    argv = ["run", "--cycles", "1", "--seed", str(records[1]["seed"]), "--randomize"]
    assert main([*argv, "--report", str(out)]) == 0
    (cycle,) = json.loads(out.read_text())["cycles"]
    same = {k: v for k, v in records[1].items() if k not in ("episode", "seed")}
    assert strip_wall(cycle) == strip_wall(same)
    assert "wall_time" in cycle and "cpu_planning_time" in same


def test_ctrl_c_writes_the_episodes_done_and_exits_130(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    ctrl_c_on_call: Callable[[Callable[..., Any], int], Callable[..., Any]],
) -> None:
    monkeypatch.setattr(episode, "run_episode", ctrl_c_on_call(episode.run_episode, 3))
    report = tmp_path / "eval.json"
    assert main(["evaluate", "--episodes", "5", "--report", str(report)]) == 130
    data = json.loads(report.read_text())
    assert data["interrupted"] is True
    assert data["summary"]["episodes"] == 2
    assert [r["episode"] for r in _lines(tmp_path / "eval.episodes.jsonl")] == [0, 1]
    err = capsys.readouterr().err
    assert "interrupted (SIGINT) after 2 episodes; continue with --resume" in err


def test_resume_skips_the_episodes_done_and_gives_the_uninterrupted_report(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    ctrl_c_on_call: Callable[[Callable[..., Any], int], Callable[..., Any]],
) -> None:
    config = EvalConfig(episodes=6, seed=11, randomize=True)
    whole = evaluate(config, report=tmp_path / "whole" / "e.json")
    cut = tmp_path / "cut" / "e.json"
    with monkeypatch.context() as m:
        m.setattr(episode, "run_episode", ctrl_c_on_call(episode.run_episode, 4))
        first = evaluate(config, report=cut)
    assert first.interrupted and first.report["summary"]["episodes"] == 3
    log = cut.with_name("e.episodes.jsonl")
    with log.open("a") as fh:  # a kill -9 in the middle of a line
        fh.write('{"episode": 3, "seed": 1')
    calls: list[int] = []
    real = episode.run_episode
    monkeypatch.setattr(episode, "run_episode", lambda s, *a: calls.append(s) or real(s, *a))
    second = evaluate(config, report=cut, resume=True)
    assert calls == [episode_seed(11, i) for i in (3, 4, 5)]  # only the episodes not done
    assert second.report["wall_execution"]["resumed_episodes"] == 3
    assert _same(second.report, whole.report)
    assert strip_wall(json.loads(cut.read_text())) == strip_wall(whole.report)
    assert sorted(r["episode"] for r in _lines(log)) == list(range(6))


def test_resume_refuses_another_evaluations_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    report = tmp_path / "e.json"
    evaluate(EvalConfig(episodes=1, seed=1), report=report)
    log = report.with_name("e.episodes.jsonl").read_bytes()
    capsys.readouterr()
    argv = ["evaluate", "--episodes", "1", "--seed", "2", "--report", str(report), "--resume"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "its episodes differ in seed; run without --resume" in err
    assert len(err.strip().splitlines()) == 1
    assert report.with_name("e.episodes.jsonl").read_bytes() == log  # untouched


def test_a_record_delivered_twice_counts_once(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A retried task may deliver records again: the driver keys them by episode."""
    real = LocalBackend.results

    def twice(self: LocalBackend, jobs: Any) -> Iterator[list[dict[str, Any]]]:
        for records in real(self, jobs):
            yield records
            yield records

    monkeypatch.setattr(LocalBackend, "results", twice)
    outcome = evaluate(EvalConfig(episodes=3, seed=2), report=tmp_path / "e.json")
    monkeypatch.undo()
    reference = evaluate(EvalConfig(episodes=3, seed=2), report=tmp_path / "ref" / "e.json")
    assert outcome.report["summary"]["episodes"] == 3
    assert len(_lines(tmp_path / "e.episodes.jsonl")) == 3
    assert _same(outcome.report, reference.report)


def test_workers_are_capped_at_the_episodes_and_warned_above_the_cores(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    cores = len(os.sched_getaffinity(0))
    with caplog.at_level(logging.WARNING, logger="kr210_sim.eval.evaluate"):
        outcome = evaluate(EvalConfig(episodes=2, workers=cores + 1))
    assert outcome.report["wall_execution"]["workers"] == 2
    assert f"--workers {cores + 1} is more than the {cores} cores" in caplog.text


def test_ray_backend_without_ray_is_a_one_line_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(sys.modules, "ray", None)  # as if the extra were not installed
    argv = ["evaluate", "--backend", "ray", "--report", str(tmp_path / "e.json")]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err == f"kr210_sim: error: {INSTALL_HINT}\n" and "'.[ray]'" in err


def test_a_ray_address_with_nothing_behind_it_fails_in_one_line(tmp_path: Path) -> None:
    """Ray retried for minutes; a port nobody listens on is refused at once (the subprocess's
    timeout only stops a hang from hanging the suite)."""
    import socket
    import subprocess

    pytest.importorskip("ray")
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # free once closed: nothing listens there
    argv = ["--backend", "ray", "--address", f"127.0.0.1:{port}", "--episodes", "1"]
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "kr210_sim",
            "evaluate",
            *argv,
            "--report",
            str(tmp_path / "e.json"),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 2
    assert done.stderr == (
        f"kr210_sim: error: cannot reach the Ray cluster at 127.0.0.1:{port}: Connection refused "
        "within 10 s; is the head node running (ray start --head)?\n"
    )


def test_address_needs_the_ray_backend(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["evaluate", "--address", "auto", "--report", str(tmp_path / "e.json")]
    assert main(argv) == 2
    assert "--address needs --backend ray" in capsys.readouterr().err


def test_a_signal_waits_for_the_end_of_a_held_block() -> None:
    """SIGTERM while a record is being written and counted: both happen, then it stops."""
    from kr210_sim.eval.evaluate import Terminated, _signals

    before = signal.getsignal(signal.SIGTERM)
    steps: list[str] = []
    with _signals() as guard:
        with pytest.raises(Terminated), guard.held():
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.05)  # the handler has run by now, and deferred the signal
            steps.append("counted")
        assert steps == ["counted"] and guard.terminated
        with pytest.raises(KeyboardInterrupt):  # outside a held block: at once
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.05)
            steps.append("never")
    assert steps == ["counted"]
    assert signal.getsignal(signal.SIGTERM) is before


def test_evaluate_plans_with_a_user_ik_in_the_workers(tmp_path: Path) -> None:
    """`evaluate --ik`: the SPEC travels to the worker processes; the broken IK (no 0.054 m
    offset) fails every episode as ik_failed, and the replay command names it."""
    from kr210_sim.util.paths import ROOT

    broken = tmp_path / "broken_ik.py"
    broken.write_text((ROOT / "examples" / "ik_dh.py").read_text().replace("0.054", "0.0"))
    spec = f"{broken}:solve"
    out = evaluate(EvalConfig(episodes=2, workers=2, ik=spec), report=tmp_path / "e.json")
    s = out.report["summary"]
    assert s["successes"] == 0 and s["failures"]["ik_failed"]["count"] == 2
    assert out.report["config"]["ik"] == spec
    assert out.report["config"]["replay"].endswith(f"--ik {spec}")


def test_an_evaluation_of_another_cell_runs_in_it_and_says_how_to_replay(tmp_path: Path) -> None:
    from kr210_sim.cell.toml import PUBLISHED_CELL

    cell = PUBLISHED_CELL.parent / "grid_4x2.toml"
    out = evaluate(EvalConfig(episodes=2, seed=1, cell=cell), report=tmp_path / "e.json")
    report = out.report
    assert not out.interrupted and report["summary"]["successes"] == 2
    assert report["config"]["cell"] == str(cell)
    assert report["config"]["replay"].endswith(f"--cell {cell}")
    records = _lines(tmp_path / "e.episodes.jsonl")
    assert all(1 <= e["slot"] <= 8 for e in records)
    assert {e["target"]["position"][1] for e in records} <= {0.15, -0.95}


def test_a_report_to_a_device_writes_no_episodes_file_beside_it(tmp_path: Path) -> None:
    """`--report /dev/null` must not create /dev/null.episodes.jsonl (a private FIFO stands in
    for the device here, read by a thread)."""
    import threading

    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    got: list[str] = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_text()))
    reader.start()
    out = evaluate(EvalConfig(episodes=1, seed=1), report=fifo)
    reader.join(30)
    assert out.episodes_path is None and json.loads(got[0])["summary"]["episodes"] == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pipe"]


def test_resume_compares_the_cell_by_content_not_by_how_its_path_is_spelled(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from kr210_sim.cell.toml import PUBLISHED_CELL

    cell = tmp_path / "mine.toml"
    cell.write_text(PUBLISHED_CELL.read_text())
    report = tmp_path / "e.json"
    evaluate(EvalConfig(episodes=1, seed=1, cell=cell), report=report)
    monkeypatch.chdir(tmp_path)  # the same file by a relative path: the same cell
    again = evaluate(
        EvalConfig(episodes=2, seed=1, cell=Path("mine.toml")), report=report, resume=True
    )
    assert again.report["wall_execution"]["resumed_episodes"] == 1
    assert again.report["summary"]["episodes"] == 2
    # The file edited (the bin moved): another cell, whatever its path; resuming would mix them.
    cell.write_text(
        PUBLISHED_CELL.read_text().replace("position = [0.0, 2.5]", "position = [0.0, 2.6]")
    )
    argv = ["evaluate", "--episodes", "3", "--seed", "1", "--cell", str(cell)]
    assert main([*argv, "--report", str(report), "--resume"]) == 2
    err = capsys.readouterr().err
    assert "its episodes differ in model_sha256; run without --resume" in err


def test_a_hand_edited_record_is_refused_on_resume(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    report = tmp_path / "e.json"
    evaluate(EvalConfig(episodes=2, seed=1), report=report)
    log = report.with_name("e.episodes.jsonl")
    lines = log.read_text().splitlines(keepends=True)
    edited = json.loads(lines[2])
    edited["episode"] = -1  # was silently skipped (and its episode never run)
    log.write_text("".join([*lines[:2], json.dumps(edited) + "\n"]))
    argv = ["evaluate", "--episodes", "2", "--seed", "1", "--report", str(report), "--resume"]
    assert main(argv) == 2
    assert "line 3 is not an episode record ('episode' is -1" in capsys.readouterr().err
    edited["episode"] = 0  # another episode's seed
    log.write_text("".join([*lines[:2], json.dumps(edited) + "\n"]))
    assert main(argv) == 2
    assert "episode 0 has seed" in capsys.readouterr().err


def test_evaluate_outputs_may_not_overwrite_its_inputs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from kr210_sim.cell.toml import PUBLISHED_CELL
    from kr210_sim.util.paths import PACKAGE_DIR

    cell = tmp_path / "mine.toml"
    cell.write_text(PUBLISHED_CELL.read_text())
    ik = tmp_path / "my_ik.py"
    ik.write_text("from kr210_sim.robot.kinematics import nearest as solve\n")
    for extra, clash in (
        (["--cell", str(cell), "--report", str(cell)], "--report and --cell name the same file"),
        (["--ik", f"{ik}:solve", "--report", str(ik)], "--report and --ik name the same file"),
        (["--report", str(PACKAGE_DIR / "robot" / "kinematics.py")], "kr210_sim's own files"),
        (["--episodes", "10000000000"], "episodes must be a whole number from 1 to 100,000,000"),
    ):
        assert main(["evaluate", "--episodes", "1", *extra]) == 2, extra
        err = capsys.readouterr().err
        assert clash in err and err.count("\n") == 1, err
    assert cell.read_text() == PUBLISHED_CELL.read_text()
    assert ik.read_text().startswith("from kr210_sim")


def test_no_success_prints_no_cycle_time(
    tmp_path: Path, no_offset_ik: str, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = [
        "evaluate",
        "--episodes",
        "1",
        "--ik",
        no_offset_ik,
        "--report",
        str(tmp_path / "e.json"),
    ]
    assert main(argv) == 1
    out = capsys.readouterr().out
    assert "cycle time    none (no episode succeeded)" in out and "0.00 s" not in out


def test_a_perceived_evaluation_scores_what_was_seen_and_replays_as_a_perceived_run(
    tmp_path: Path,
) -> None:
    """`evaluate --perceive --randomize`: every record carries its perception scored against
    the truth, the summary sums them up, and an episode replays as `run --perceive`."""
    from kr210_sim.cell.toml import PUBLISHED_CELL

    cell = PUBLISHED_CELL.parent / "cluttered.toml"
    config = EvalConfig(episodes=3, seed=2, randomize=True, cell=cell, perceive=True, workers=2)
    out = evaluate(config, report=tmp_path / "e.json")
    report = out.report
    records = sorted(_lines(tmp_path / "e.episodes.jsonl"), key=lambda r: r["episode"])
    blocks = [r["perception"] for r in records]
    assert all(b["looks"] >= 1 and b["clusters"] for b in blocks)
    p = report["summary"]["perception"]
    assert p["episodes"] == 3 and p["recognised"] == sum(b["right_object"] for b in blocks)
    errors = [b["position_error_mm"] for b in blocks if b["position_error_mm"] is not None]
    assert p["position_error_mm"]["max"] == max(errors)
    assert p["position_error_mm"]["median"] == pytest.approx(sorted(errors)[1], abs=1e-6)
    assert report["config"]["perceive"] is True
    assert " --randomize --perceive" in report["config"]["replay"]
    # the episode is `run --perceive` of its seed, field for field but the measured ones
    replay = tmp_path / "replay.json"
    argv = ["run", "--cycles", "1", "--seed", str(records[0]["seed"]), "--randomize"]
    argv += ["--perceive", "--cell", str(cell), "--report", str(replay)]
    assert main(argv) in (0, 1)
    (cycle,) = json.loads(replay.read_text())["cycles"]
    same = {k: v for k, v in records[0].items() if k not in ("episode", "seed")}
    assert strip_wall(cycle) == strip_wall(same)
    # told the truth, the same episodes carry no perception at all
    told = evaluate(EvalConfig(episodes=1, seed=2, randomize=True, cell=cell))
    assert "perception" not in told.report["summary"]
    assert "perceive" not in told.report["config"]
