"""The episodes file: naming, round trip, a torn last line, refusing a foreign or corrupt file."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from kr210_sim.errors import ConfigError
from kr210_sim.eval.stream import EpisodeWriter, episodes_path, read_records

IDENTITY: dict[str, Any] = {"seed": 3, "randomize": True, "scene": None, "versions": {"x": "1"}}


def _rec(i: int, seed: int, success: bool) -> dict[str, Any]:
    """An episode record with the fields the summary reads."""
    return {
        "episode": i,
        "seed": seed,
        "success": success,
        "reason": None if success else "dropped_in_transit",
        "grasp_attempts": 1,
        "max_tracking_error_deg": [0.1] * 6,
        "creep_mm": 1.0,
        "cycle_time": 20.0,
    }


RECORDS = [_rec(i, 10 + i, i != 1) for i in (2, 0, 1)]


def _write(path: Path) -> None:
    with EpisodeWriter(path, IDENTITY, append=False) as w:
        w.write(RECORDS[:2])
        w.write(RECORDS[2:])


def test_episodes_path_sits_beside_the_report() -> None:
    assert episodes_path(Path("r/evaluate.json")) == Path("r/evaluate.episodes.jsonl")
    assert episodes_path(Path("sweep")) == Path("sweep.episodes.jsonl")


def test_round_trip_in_arrival_order(tmp_path: Path) -> None:
    path = tmp_path / "e.episodes.jsonl"
    _write(path)
    lines = path.read_text().splitlines()
    assert len(lines) == 4 and '"kind": "kr210_sim.evaluate.episodes"' in lines[0]
    assert list(read_records(path, IDENTITY)) == RECORDS


def test_appending_continues_the_file(tmp_path: Path) -> None:
    path = tmp_path / "e.episodes.jsonl"
    _write(path)
    with EpisodeWriter(path, IDENTITY, append=True) as w:
        w.write([_rec(3, 13, True)])
    assert [r["episode"] for r in read_records(path, IDENTITY)] == [2, 0, 1, 3]


def test_a_line_cut_short_is_dropped_and_truncated(tmp_path: Path) -> None:
    path = tmp_path / "e.episodes.jsonl"
    _write(path)
    whole = path.read_bytes()
    with path.open("ab") as fh:
        fh.write(b'{"episode": 3, "se')
    assert list(read_records(path, IDENTITY)) == RECORDS
    assert path.read_bytes() == whole


def test_a_complete_last_line_without_newline_is_dropped(tmp_path: Path) -> None:
    """The newline is written with the record: without it the write did not finish."""
    path = tmp_path / "e.episodes.jsonl"
    _write(path)
    whole = path.read_bytes()
    path.write_bytes(whole + b'{"episode": 3}')
    assert len(list(read_records(path, IDENTITY))) == 3
    assert path.read_bytes() == whole


@pytest.mark.parametrize(
    ("line", "problem"),
    [
        ({**_rec(3, 13, True), "episode": -1}, "'episode' is -1, not a whole number >= 0"),
        ({**_rec(3, 13, True), "episode": "3"}, "'episode' is '3', not a whole number >= 0"),
        ({k: v for k, v in _rec(3, 13, True).items() if k != "episode"}, "no 'episode'"),
        ([_rec(3, 13, True)], "a JSON list, not an object"),
    ],
)
def test_a_line_that_is_not_an_episode_record_is_an_error_not_skipped(
    tmp_path: Path, line: Any, problem: str
) -> None:
    import json

    path = tmp_path / "e.episodes.jsonl"
    _write(path)
    with path.open("a") as fh:
        fh.write(json.dumps(line) + "\n")
    with pytest.raises(ConfigError, match=None) as exc:
        list(read_records(path, IDENTITY))
    assert f"line 5 is not an episode record ({problem})" in str(exc.value)


def test_a_corrupt_middle_line_is_an_error(tmp_path: Path) -> None:
    path = tmp_path / "e.episodes.jsonl"
    _write(path)
    lines = path.read_bytes().splitlines(keepends=True)
    path.write_bytes(b"".join([lines[0], b"garbage\n", *lines[1:]]))
    with pytest.raises(ConfigError, match="line 2 is corrupt"):
        list(read_records(path, IDENTITY))


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"seed": 4}, "differ in seed"),
        ({"randomize": False, "versions": {"x": "2"}}, "differ in randomize, versions"),
    ],
)
def test_another_evaluations_file_is_refused(
    tmp_path: Path, change: dict[str, Any], message: str
) -> None:
    path = tmp_path / "e.episodes.jsonl"
    _write(path)
    with pytest.raises(ConfigError, match=message):
        list(read_records(path, {**IDENTITY, **change}))


def test_a_file_that_is_not_an_episodes_file_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "e.episodes.jsonl"
    path.write_text('{"kind": "kr210_sim.run"}\n')
    with pytest.raises(ConfigError, match="is not an episodes file"):
        list(read_records(path, IDENTITY))
