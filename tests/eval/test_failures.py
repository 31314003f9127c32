"""Failed episodes re-run and recorded: named by seed and reason, the very episode, with the
user's IK when the evaluation had one."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from kr210_sim.cli import main
from kr210_sim.eval.failures import record_episode, record_failures
from kr210_sim.media.recording import read_recording


def test_record_episode_names_the_file_by_seed_and_reason(tmp_path: Path) -> None:
    from kr210_sim.eval.episode import run_episode

    seed = 1234
    expected = run_episode(seed, True)
    made = record_episode(seed, True, tmp_path / "failures")
    assert made.reason == (expected.reason or "success")
    assert made.path == tmp_path / "failures" / f"{seed}_{made.reason}.npz"
    rec = read_recording(made.path)
    assert rec.frames == made.frames > 30
    cycle = rec.meta["summary"]
    assert cycle["cycles"] == 1 and cycle["successes"] == int(expected.success)
    assert rec.meta["run"] == {"seed": seed, "slot": 0, "randomize": True}


def test_record_failures_records_only_the_failed_episodes(tmp_path: Path) -> None:
    records = [
        {"seed": 11, "success": True, "reason": None},
        {"seed": 1234, "success": False, "reason": "as evaluated"},
    ]
    assert record_failures(records[:1], True, tmp_path / "none") == []
    assert not (tmp_path / "none").exists()  # no failure, no folder
    made = record_failures(records, True, tmp_path / "f")
    assert [m.path.name.split("_")[0] for m in made] == ["1234"]
    assert made[0].path.exists()


def test_evaluate_records_its_failed_episodes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`evaluate --record-failures DIR` in a cell whose shelf is out of reach: the episode
    fails, and its recording is named by seed and reason and reads back."""
    from kr210_sim.cell.toml import PUBLISHED_CELL

    cell = PUBLISHED_CELL.parent / "unreachable.toml"
    out = tmp_path / "fails"
    argv = ["evaluate", "--episodes", "1", "--seed", "3", "--cell", str(cell)]
    argv += ["--report", str(tmp_path / "e.json"), "--record-failures", str(out)]
    assert main(argv) == 1
    assert "failures recorded: 1" in capsys.readouterr().out
    (made,) = out.iterdir()
    failed = json.loads((tmp_path / "e.json").read_text())["failed_episodes"][0]
    assert made.name == f"{failed['seed']}_{failed['reason']}.npz"
    assert read_recording(made).meta["summary"]["successes"] == 0


def test_evaluate_records_the_failed_episodes_of_a_user_ik(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`evaluate --ik SPEC --record-failures DIR`: the re-run plans with the same IK, so the
    recording is of the very failure (here an IK that answers nothing: ik_failed)."""
    ik = tmp_path / "my_ik.py"
    ik.write_text("def solve(T, q_ref):\n    return None\n")
    out = tmp_path / "fails"
    argv = ["evaluate", "--episodes", "1", "--seed", "3", "--ik", f"{ik}:solve"]
    argv += ["--report", str(tmp_path / "e.json"), "--record-failures", str(out)]
    assert main(argv) == 1
    assert "failures recorded: 1" in capsys.readouterr().out
    (made,) = out.iterdir()
    failed = json.loads((tmp_path / "e.json").read_text())["failed_episodes"][0]
    assert failed["reason"] == "ik_failed"
    assert made.name == f"{failed['seed']}_ik_failed.npz"
    assert read_recording(made).meta["summary"]["successes"] == 0


def test_a_perceived_episode_is_recorded_perceived(tmp_path: Path) -> None:
    """`evaluate --perceive --record-failures`: the re-run perceives as the episode did (the
    same estimate, so the same outcome), not from the truth."""
    from kr210_sim.eval.episode import run_episode
    from kr210_sim.util.paths import SCENES_DIR

    cell = SCENES_DIR / "cells" / "cluttered.toml"
    seed = 77
    expected = run_episode(seed, True, cell, perceive=True)
    assert expected.perception is not None
    made = record_episode(seed, True, tmp_path, cell, perceive=True)
    assert made.reason == (expected.reason or "success")
    p = read_recording(made.path).meta["summary"]["perception"]
    assert p["cycles"] == 1 and p["recognised"] == int(expected.perception["right_object"])
    assert p["position_error_mm"]["max"] == expected.perception["position_error_mm"]
