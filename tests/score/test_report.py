"""Reports: atomic writes, summaries, and the wall-time filter."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from kr210_sim.errors import ConfigError
from kr210_sim.score.report import strip_wall, summarise
from kr210_sim.util.outputs import write_json_atomic


def test_atomic_write_replaces_whole_file(tmp_path: Path) -> None:
    path = tmp_path / "r.json"
    write_json_atomic(path, {"a": 1})
    write_json_atomic(path, {"b": [1, 2]})
    assert json.loads(path.read_text()) == {"b": [1, 2]}
    assert [p.name for p in tmp_path.iterdir()] == ["r.json"]


def test_failed_write_keeps_the_old_report(tmp_path: Path) -> None:
    path = tmp_path / "r.json"
    write_json_atomic(path, {"a": 1})
    with pytest.raises(ValueError):
        write_json_atomic(path, {"a": float("nan")})  # not valid JSON
    assert json.loads(path.read_text()) == {"a": 1}
    assert [p.name for p in tmp_path.iterdir()] == ["r.json"]


def test_unwritable_folder(tmp_path: Path) -> None:
    f = tmp_path / "f"
    f.write_text("")
    with pytest.raises(ConfigError, match="cannot create the folder"):
        write_json_atomic(f / "x" / "r.json", {})


def test_empty_summary() -> None:
    s = summarise([], wall_time=1.0)
    assert (s["cycles"], s["successes"], s["success_rate"]) == (0, 0, 0.0)


def test_strip_wall_drops_exactly_the_measured_fields() -> None:
    report = {
        "summary": {"wall_time_s": 2.0, "cpu_planning_time_s": {"max": 1.0}, "cycles": 1},
        "cycles": [{"wall_time": 1.0, "cpu_planning_time": 0.5, "x": 2, "time": 3.0}],
        "wall_execution": {"workers": 2},
        "sim_time": 4.0,
    }
    assert strip_wall(report) == {
        "summary": {"cycles": 1},
        "cycles": [{"x": 2, "time": 3.0}],
        "sim_time": 4.0,
    }


def test_the_table_of_a_run_that_recognised_nothing() -> None:
    """No cycle recognised: no position errors to give, and the table says 0/n (it raised a
    TypeError on None)."""
    from kr210_sim.score.report import summary_table

    summary = summarise([])
    summary["perception"] = {"recognised": 0, "cycles": 2, "position_error_mm": None}
    table = summary_table(summary)
    assert "recognised" in table and "0/2\n" in table + "\n" and "error median" not in table
