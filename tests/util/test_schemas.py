"""The shipped JSON Schemas: valid draft 2020-12, strict and documented; real run reports and
every shipped cell file pass them, a wrong type, a missing field or an unknown key fails."""

from __future__ import annotations

import copy
import dataclasses
import json
import tomllib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from kr210_sim.cell import sensing_toml
from kr210_sim.cell import toml as cell_toml
from kr210_sim.cli import main
from kr210_sim.errors import ConfigError
from kr210_sim.jobs import run_job
from kr210_sim.sim.runner import RunConfig
from kr210_sim.util.schemas import SCHEMAS, load_schema

jsonschema = pytest.importorskip("jsonschema")

REPO = Path(__file__).resolve().parents[2]
#: Every cell file shipped: the published ones and any in examples/.
CELLS = sorted([*REPO.glob("scenes/cells/*.toml"), *REPO.glob("examples/**/*.toml")])
WORKED_IK = f"{REPO / 'examples' / 'ik_dh.py'}:solve"


def _validator(name: str) -> Any:
    return jsonschema.Draft202012Validator(load_schema(name))


def _objects(node: Any, where: str = "") -> Iterator[tuple[str, dict[str, Any]]]:
    """Every subschema that declares properties, with its path."""
    if isinstance(node, dict):
        if "properties" in node:
            yield where, node
        for key, value in node.items():
            yield from _objects(value, f"{where}/{key}")
    elif isinstance(node, list):
        for i, value in enumerate(node):
            yield from _objects(value, f"{where}/{i}")


@pytest.mark.parametrize("name", SCHEMAS)
def test_each_schema_is_draft_2020_12_strict_and_documented(name: str) -> None:
    schema = load_schema(name)
    assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    jsonschema.Draft202012Validator.check_schema(schema)
    for where, node in _objects(schema):
        assert node.get("additionalProperties") is False, f"{name}{where} is not strict"
        assert node.get("description"), f"{name}{where} has no description"
        for key, prop in node["properties"].items():
            assert prop.get("description"), f"{name}{where}/{key} has no description"
            assert set(node["required"]) <= set(node["properties"])


def test_an_unknown_schema_is_one_line() -> None:
    with pytest.raises(
        ConfigError, match=r"no schema 'evaluate' \(there are: run, episode, cell\)"
    ):
        load_schema("evaluate")


# -- the run report ----------------------------------------------------------------------------
@pytest.fixture(scope="module")
def reports(tmp_path_factory: pytest.TempPathFactory) -> dict[str, dict[str, Any]]:
    """Reports made by real runs: the built-in IK, a user's IK (the summary's ``ik`` block), one
    on a cell file with obstacles, and a ``--perceive`` one (its ``perception`` blocks)."""
    from kr210_sim.sandbox.user_ik import load_ik

    d = tmp_path_factory.mktemp("reports")
    made = {
        "builtin": run_job(RunConfig(cycles=2, seed=1), d / "builtin.json"),
        "user_ik": run_job(RunConfig(cycles=1, seed=2), d / "ik.json", ik=load_ik(WORKED_IK)),
        "column": run_job(
            RunConfig(cycles=1, seed=0), d / "column.json", cell=REPO / "scenes/cells/column.toml"
        ),
        "perceive": run_job(
            RunConfig(cycles=1, seed=0, perceive=True),
            d / "perceive.json",
            cell=REPO / "scenes/cells/cluttered.toml",
        ),
    }
    return {name: json.loads(json.dumps(job.report)) for name, job in made.items()}


@pytest.mark.slow
def test_real_run_reports_pass_the_run_schema(reports: dict[str, dict[str, Any]]) -> None:
    validator = _validator("run")
    for name, report in reports.items():
        errors = [f"{list(e.absolute_path)}: {e.message}" for e in validator.iter_errors(report)]
        assert not errors, (name, errors)
    assert "branches" in reports["user_ik"]["summary"]["ik"]  # the optional blocks were there
    assert "perception" in reports["perceive"]["summary"]
    assert reports["perceive"]["config"]["perceive"] is True


def test_the_report_of_a_run_stopped_before_its_first_cycle_passes(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """No cycles, no cell, no wall figures: every optional block left out."""
    import signal

    from kr210_sim.sim.session import unstarted_report
    from kr210_sim.util.interrupts import Interrupted

    report = json.loads(json.dumps(unstarted_report(RunConfig(cycles=3), Interrupted(15))))
    assert report["cycles"] == [] and report["interrupted_by"] == signal.SIGTERM.name
    assert not [e.message for e in _validator("run").iter_errors(report)]
    assert "interrupted before the first cycle" in capsys.readouterr().err


@pytest.mark.slow
@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda r: r["cycles"][0].__setitem__("cycle_time", "4.5 s"), "is not of type 'number'"),
        (lambda r: r.pop("summary"), "'summary' is a required property"),
        (lambda r: r["summary"].__setitem__("cycle_tme_mean", 4.5), "Additional properties"),
        (lambda r: r["config"]["motion"].__setitem__("ready_q", [0.0] * 5), "is too short"),
        (lambda r: r.__setitem__("kind", "kr210_sim.evaluate"), "was expected"),
    ],
)
def test_a_broken_report_fails_the_run_schema(
    reports: dict[str, dict[str, Any]], change: Any, message: str
) -> None:
    report = copy.deepcopy(reports["builtin"])
    change(report)
    errors = [e.message for e in _validator("run").iter_errors(report)]
    assert any(message in e for e in errors), errors


def test_the_run_schema_lists_every_setting_of_a_run() -> None:
    from kr210_sim.cell.spec import MotionConfig

    config = load_schema("run")["properties"]["config"]
    assert set(config["properties"]) == {f.name for f in dataclasses.fields(RunConfig)}
    motion = config["properties"]["motion"]["properties"]
    assert set(motion) == {f.name for f in dataclasses.fields(MotionConfig)}


# -- evaluate's episode records -----------------------------------------------------------------
@pytest.mark.slow
def test_evaluates_episode_records_pass_the_episode_schema(tmp_path: Path) -> None:
    """The records of a real ``evaluate`` (its episodes file after the header), and the shared
    part: a record is the run report's cycle record after its episode number and seed."""
    report = tmp_path / "eval.json"
    assert main(["evaluate", "--episodes", "2", "--report", str(report)]) == 0
    lines = (tmp_path / "eval.episodes.jsonl").read_text().splitlines()
    header, records = json.loads(lines[0]), [json.loads(line) for line in lines[1:]]
    assert header["kind"] == "kr210_sim.evaluate.episodes" and len(records) == 2
    episode, run = _validator("episode"), load_schema("run")
    for record in records:
        assert not [e.message for e in episode.iter_errors(record)]
    props = load_schema("episode")["properties"]
    assert {k: v for k, v in props.items() if k not in ("episode", "seed")} == run["$defs"][
        "cycle"
    ]["properties"]
    broken = {**records[0], "episode": -1}
    assert any("less than the minimum" in e.message for e in episode.iter_errors(broken))
    broken = {k: v for k, v in records[0].items() if k != "seed"}
    assert any("'seed' is a required" in e.message for e in episode.iter_errors(broken))


# -- the cell file -------------------------------------------------------------------------------
def test_every_shipped_cell_passes_the_cell_schema() -> None:
    assert len(CELLS) >= 8
    validator = _validator("cell")
    for path in CELLS:
        doc = tomllib.loads(path.read_text())
        errors = [f"{list(e.absolute_path)}: {e.message}" for e in validator.iter_errors(doc)]
        assert not errors, (path.name, errors)


def test_the_cell_schema_knows_the_keys_the_loader_reads() -> None:
    props = load_schema("cell")["properties"]
    assert set(props) == cell_toml._SECTIONS

    def keys(section: str) -> set[str]:
        node = props[section]
        return set((node.get("items") or node)["properties"])

    assert keys("shelf") == cell_toml._SHELF_KEYS
    assert keys("bin") == cell_toml._BIN_KEYS
    assert keys("obstacles") == cell_toml._OBSTACLE_KEYS
    assert keys("robot") == cell_toml._ROBOT_KEYS
    assert keys("target") == cell_toml._TARGET_KEYS
    assert set(props["target"]["properties"]["randomize"]["properties"]) == cell_toml._RANDOM_KEYS
    assert keys("sensors") == sensing_toml._SENSOR_KEYS
    assert keys("objects") == sensing_toml._OBJECT_KEYS
    assert keys("clutter") == sensing_toml._CLUTTER_KEYS
    assert keys("pick") == sensing_toml._PICK_KEYS


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda c: c["shelf"].__setitem__("rows", "3"), "is not of type 'integer'"),
        (lambda c: c.pop("bin"), "'bin' is a required property"),
        (lambda c: c["target"].__setitem__("colour", [1, 0, 0]), "Additional properties"),
        (lambda c: c["bin"].__setitem__("size", [1.0, 1.0]), "is too short"),
        (lambda c: c.__setitem__("robot", {}), "'ready_q' is a required property"),
    ],
)
def test_a_broken_cell_fails_the_cell_schema(change: Any, message: str) -> None:
    doc = tomllib.loads((REPO / "scenes/cells/published.toml").read_text())
    change(doc)
    errors = [e.message for e in _validator("cell").iter_errors(doc)]
    assert any(message in e for e in errors), errors
