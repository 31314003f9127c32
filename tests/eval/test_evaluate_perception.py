"""``evaluate --perceive --perception SPEC``: every worker runs the user's function in its jail,
the records score it against the truth, and its faults are the episodes' reasons."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from kr210_sim.errors import ConfigError
from kr210_sim.eval.evaluate import EvalConfig, evaluate

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "examples" / "perception_simple.py"
CLUTTERED = REPO / "scenes" / "cells" / "cluttered.toml"


@pytest.mark.parametrize(
    ("kwargs", "error"),
    [
        ({"perception": "x.py:f"}, "--perception needs --perceive (it replaces our perception)"),
        (
            {"perception_timeout": 2.0},
            "--perception-timeout needs --perception SPEC and a time > 0 s",
        ),
        (
            {"perceive": True, "perception": "x.py:f", "perception_timeout": 0.0},
            "--perception-timeout needs --perception SPEC and a time > 0 s",
        ),
    ],
)
def test_a_bad_perception_config_is_one_line(kwargs: dict, error: str) -> None:  # type: ignore[type-arg]
    with pytest.raises(ConfigError) as caught:
        EvalConfig(episodes=1, **kwargs)
    assert str(caught.value) == error


def test_the_command_refuses_a_bad_spec_before_any_episode(
    tmp_path: Path, capsys: pytest.CaptureFixture, jail_ok: None
) -> None:
    from kr210_sim.cli import main

    report = tmp_path / "e.json"
    argv = ["evaluate", "--episodes", "1", "--perceive", "--perception", f"{tmp_path}/no.py:f"]
    assert main([*argv, "--report", str(report)]) == 2
    err = capsys.readouterr().err
    assert (
        err
        == f"kr210_sim: error: --perception '{tmp_path}/no.py:f': no such file {tmp_path}/no.py\n"
    )
    assert not report.exists()


@pytest.mark.chaotic
def test_workers_pick_with_the_users_function_and_its_faults_are_reasons(
    tmp_path: Path, capsys: pytest.CaptureFixture, jail_ok: None
) -> None:
    user = tmp_path / "mine.py"
    user.write_text(EXAMPLE.read_text() + "\n\ndef broken(look):\n    raise OSError('no camera')\n")
    config = EvalConfig(
        episodes=2, workers=2, cell=CLUTTERED, perceive=True, perception=f"{user}:perceive"
    )
    out = evaluate(config, tmp_path / "good.json")
    report = out.report
    assert report["summary"]["successes"] == 2
    assert report["summary"]["perception"]["recognised"] == 2
    assert report["config"]["perception"] == f"{user}:perceive"
    assert report["config"]["perception_timeout_s"] == 10.0
    assert f"--perceive --perception {user}:perceive" in report["config"]["replay"]
    lines = (tmp_path / "good.episodes.jsonl").read_text().splitlines()
    records = [json.loads(x) for x in lines if '"episode"' in x]
    assert len(records) == 2
    for r in records:
        assert r["perception"]["right_object"] and r["perception"]["position_error_mm"] < 10.0

    from kr210_sim.cli import main

    argv = ["evaluate", "--episodes", "1", "--workers", "1", "--cell", str(CLUTTERED)]
    argv += ["--perceive", "--perception", f"{user}:broken", "--report", str(tmp_path / "b.json")]
    assert main(argv) == 1
    assert "  recognised    0/1\n" in capsys.readouterr().out  # it raised a TypeError on None
    (failed,) = json.loads((tmp_path / "b.json").read_text())["failed_episodes"]
    assert failed["reason"] == "not_seen"
    assert failed["perception"]["reason"].startswith(
        "mine.py:broken raised OSError: no camera (mine.py line"
    )


def test_resume_refuses_the_episodes_of_another_version_of_the_function(
    tmp_path: Path, jail_ok: None
) -> None:
    user = tmp_path / "blind.py"
    user.write_text("def perceive(look):\n    return []\n")
    config = EvalConfig(
        episodes=2, workers=1, cell=CLUTTERED, perceive=True, perception=f"{user}:perceive"
    )
    report = tmp_path / "e.json"
    evaluate(EvalConfig(**{**_fields(config), "episodes": 1}), report)
    user.write_text("def perceive(look):\n    return [] \n")  # edited: another function
    with pytest.raises(ConfigError, match="its episodes differ in perception"):
        evaluate(config, report, resume=True)


def _fields(config: EvalConfig) -> dict:  # type: ignore[type-arg]
    import dataclasses

    return {f.name: getattr(config, f.name) for f in dataclasses.fields(config)}
