"""The Python API: the same figures as the CLI, typed results, errors as the package's types."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import kr210_sim
from kr210_sim.api import RunInterrupted, RunReport
from kr210_sim.cli import main
from kr210_sim.errors import ConfigError, IkSpecError, Kr210SimError
from kr210_sim.robot import kinematics
from kr210_sim.score.report import strip_wall
from kr210_sim.score.result import CycleResult
from kr210_sim.sim.runner import Runner

ROOT = Path(__file__).resolve().parents[1]
#: The how-to page of the Python API (what was the README's "Use it from Python").
PYTHON_HOW_TO = ROOT / "docs" / "how-to" / "python.md"


def test_run_returns_what_the_cli_writes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cli_path = tmp_path / "cli.json"
    assert main(["run", "--cycles", "2", "--seed", "4", "--report", str(cli_path)]) == 0
    cli_out = capsys.readouterr().out
    api_path = tmp_path / "api.json"
    report = kr210_sim.run(cycles=2, seed=4, report=api_path)
    assert isinstance(report, RunReport) and report.path == api_path
    from_cli = json.loads(cli_path.read_text())
    assert strip_wall(report.to_dict()) == strip_wall(from_cli)
    assert strip_wall(json.loads(report.to_json())) == strip_wall(from_cli)
    assert strip_wall(json.loads(api_path.read_text())) == strip_wall(from_cli)
    s = report.summary
    assert (s["cycles"], s["successes"], s["success_rate"]) == (2, 2, 1.0)
    assert [c.slot for c in report.cycles] == [c["slot"] for c in from_cli["cycles"]]
    assert all(isinstance(c, CycleResult) and c.success and c.reason is None for c in report.cycles)
    assert f"[2/2] slot {report.cycles[1].slot}  ok" in cli_out
    assert report.passed(1.0) and report.interrupted_by is None
    with pytest.raises(TypeError):
        report.summary["cycles"] = 3  # type: ignore[index]
    report.to_dict()["summary"]["cycles"] = 3  # a copy
    assert report.summary["cycles"] == 2


def test_run_without_a_report_path_writes_nothing_and_logs_its_lines(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    monkeypatch.chdir(tmp_path)
    with caplog.at_level("INFO", logger="kr210_sim.api"):
        report = kr210_sim.run(cycles=1, slot=7, seed=2)
    assert report.path is None and list(tmp_path.iterdir()) == []
    assert [r.getMessage()[:14] for r in caplog.records] == ["[1/1] slot 7  "]


def test_ik_as_a_python_callable() -> None:
    calls = []

    def my_ik(T: np.ndarray, q_ref: np.ndarray) -> np.ndarray:
        calls.append(1)
        return kinematics.nearest(T, q_ref)

    ours = kr210_sim.run(cycles=1, seed=5)
    theirs = kr210_sim.run(cycles=1, seed=5, ik=my_ik)
    assert theirs.summary["ik"]["spec"].endswith(":test_ik_as_a_python_callable.<locals>.my_ik")
    assert theirs.summary["ik"]["calls"] == len(calls) > 20
    assert theirs.cycles[0].success
    assert theirs.cycles[0].cycle_time == ours.cycles[0].cycle_time
    by_spec = kr210_sim.run(cycles=1, seed=5, ik="kr210_sim.robot.kinematics:nearest")
    assert by_spec.summary["ik"]["spec"] == "kr210_sim.robot.kinematics:nearest"


def test_a_callable_ik_that_misses_fails_its_cycle_not_the_call() -> None:
    report = kr210_sim.run(cycles=1, slot=5, ik=lambda T, q_ref: np.zeros(6))
    (cycle,) = report.cycles
    assert cycle.reason == "ik_failed" and "misses the pose" in cycle.detail


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"cycles": 0}, ConfigError, "cycles must be a whole number from 1 to 10000"),
        ({"slot": 12}, ConfigError, "slot must be 0 (random) or 1-9 in cell 'published', got 12"),
        ({"seed": -1}, ConfigError, "seed must be a whole number >= 0, got -1"),
        ({"randomize": "yes"}, ConfigError, "randomize must be True or False"),
        ({"ik": 3}, IkSpecError, "ik must be a SPEC string or a callable"),
        ({"ik": "no_such_module:solve"}, IkSpecError, "no module named 'no_such_module'"),
        ({"report": 3}, ConfigError, "report must be a path (str or Path), got a int"),
        ({"cycles": True}, ConfigError, "cycles must be a whole number, got True"),
        ({"out": "stdout"}, ConfigError, "out must be a text stream with a write method"),
    ],
)
def test_bad_arguments_raise_the_packages_errors(
    kwargs: dict[str, Any], error: type[Kr210SimError], message: str
) -> None:
    with pytest.raises(error) as exc:
        kr210_sim.run(**kwargs)
    assert message in str(exc.value) and "\n" not in str(exc.value)


def test_ctrl_c_raises_with_the_report_of_the_cycles_done(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    ctrl_c_on_call: Callable[[Callable[..., Any], int], Callable[..., Any]],
) -> None:
    monkeypatch.setattr(Runner, "run_cycle", ctrl_c_on_call(Runner.run_cycle, 2))
    path = tmp_path / "run.json"
    with pytest.raises(RunInterrupted) as exc:
        kr210_sim.run(cycles=5, slot=5, report=path)
    assert isinstance(exc.value, KeyboardInterrupt)
    report = exc.value.report
    assert isinstance(report, RunReport) and report.interrupted_by == "SIGINT"
    assert len(report.cycles) == 1 and report.summary["cycles"] == 1
    assert json.loads(path.read_text())["summary"]["cycles"] == 1


def test_ik_check_takes_a_callable() -> None:
    graded = kr210_sim.ik_check(kinematics.nearest, cases=20, seed=1)
    assert graded.passed and graded.summary["cases"] == len(graded.cases) > 20
    assert graded.data["config"]["ik"] == "kr210_sim.robot.kinematics:nearest"

    def off(T: np.ndarray, q_ref: np.ndarray) -> np.ndarray:
        return kinematics.nearest(T, q_ref) + 0.01

    assert not kr210_sim.ik_check(off, cases=0).passed
    with pytest.raises(ConfigError, match="cases must be a whole number >= 0"):
        kr210_sim.ik_check(off, cases=-1)


def test_evaluate_wraps_the_evaluation(tmp_path: Path) -> None:
    from kr210_sim.eval.evaluate import EvalConfig, evaluate

    path = tmp_path / "eval.json"
    report = kr210_sim.evaluate(episodes=2, seed=3, report=path)
    direct = evaluate(EvalConfig(episodes=2, seed=3), report=tmp_path / "direct.json")
    assert not direct.interrupted

    def same(d: dict[str, object]) -> dict[str, object]:
        return {k: v for k, v in strip_wall(d).items() if k != "episodes_file"}

    assert same(report.to_dict()) == same(direct.report)
    assert same(json.loads(path.read_text())) == same(direct.report)
    assert report.failed_episodes == () and report.data["episodes_file"] == "eval.episodes.jsonl"
    with pytest.raises(ConfigError, match="episodes must be a whole number"):
        kr210_sim.evaluate(episodes=0)
    with pytest.raises(ConfigError, match=r"evaluate: .*unexpected keyword argument 'colour'"):
        kr210_sim.evaluate(episodes=1, colour="red")


def test_numpy_whole_numbers_are_whole_numbers() -> None:
    report = kr210_sim.run(cycles=np.int64(1), seed=np.int32(2), slot=np.int64(5))
    assert report.summary["cycles"] == 1 and report.cycles[0].slot == 5


def test_evaluate_takes_a_function_its_workers_can_load() -> None:
    ours = kr210_sim.evaluate(episodes=1, seed=3, ik=kinematics.nearest)
    assert ours.summary["successes"] == 1
    assert ours.data["config"]["ik"] == "kr210_sim.robot.kinematics:nearest"
    with pytest.raises(ConfigError, match=r"cannot be loaded there .* pass ik='path/to/file\.py"):
        kr210_sim.evaluate(episodes=1, ik=lambda T, q: kinematics.nearest(T, q))


def test_importing_the_package_loads_no_simulation_code() -> None:
    probe = (
        "import sys, kr210_sim; "
        "print(sorted(m for m in ('kr210_sim.api', 'kr210_sim.sim.runner', 'gymnasium') "
        "if m in sys.modules)); "
        "import kr210_sim.eval.evaluate as e; "
        "print(callable(kr210_sim.evaluate), e.EvalConfig.__name__)"
    )
    out = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, check=True
    ).stdout
    assert out.split("\n")[:2] == ["[]", "True EvalConfig"]


def _how_to_python_blocks() -> list[str]:
    text = PYTHON_HOW_TO.read_text()
    return re.findall(r"```python\n(.*?)```", text, flags=re.S)


def test_the_readmes_run_signature_names_real_parameters_scene_and_cell() -> None:
    """The how-to's one-line list of ``kr210_sim.run``'s parameters: each is one, with ``cell``."""
    import inspect

    listed = re.findall(r"`kr210_sim\.run\((cycles[^)]*)\)`", PYTHON_HOW_TO.read_text())
    assert len(listed) == 1
    names = [n.strip() for n in listed[0].split(",")]
    assert set(names) <= set(inspect.signature(kr210_sim.run).parameters)
    assert {"scene", "cell"} <= set(names)


@pytest.mark.slow
def test_the_readme_example_runs_as_written(tmp_path: Path) -> None:
    blocks = _how_to_python_blocks()
    assert blocks, "docs/how-to/python.md has Python blocks"
    for block in blocks:
        if "gymnasium" in block:
            pytest.importorskip("gymnasium")
        proc = subprocess.run(
            [sys.executable, "-c", block], cwd=tmp_path, capture_output=True, text=True, timeout=300
        )
        assert proc.returncode == 0, proc.stderr


def test_a_failed_video_raises_with_the_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import imageio_ffmpeg

    from kr210_sim.errors import RenderError, VideoFailedError

    def missing() -> str:
        raise RuntimeError("No ffmpeg exe could be found")

    monkeypatch.setattr(imageio_ffmpeg, "get_ffmpeg_exe", missing)
    path = tmp_path / "r.json"
    with pytest.raises(VideoFailedError) as exc:
        kr210_sim.run(cycles=1, slot=1, report=path, video=tmp_path / "v.mp4")
    assert isinstance(exc.value, RenderError) and "ffmpeg is not available" in str(exc.value)
    report = exc.value.report
    assert isinstance(report, RunReport) and report.video_error == str(exc.value)
    assert report.cycles[0].success and report.video_path is None
    assert json.loads(path.read_text())["summary"]["successes"] == 1


def _timeless(value: Any) -> Any:
    """``value`` without its wall-clock times (every ``wall_time*`` key), CPU times (``cpu_s``:
    the jail's) and memory peaks (``memory_peak_mb``: the jail's)."""
    if isinstance(value, dict):
        kept = {
            k: v
            for k, v in value.items()
            if not k.startswith("wall_time") and k not in ("cpu_s", "memory_peak_mb")
        }
        return {k: _timeless(v) for k, v in kept.items()}
    if isinstance(value, list):
        return [_timeless(v) for v in value]
    return value


@pytest.mark.slow
def test_grade_gives_the_verdicts_of_the_command(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    folder = tmp_path / "class"
    folder.mkdir()
    src = (ROOT / "examples" / "ik_dh.py").read_text()
    (folder / "correct.py").write_text(src)
    (folder / "no_offset.py").write_text(src.replace("\nA3 = -0.054", "\nA3 = 0.0"))
    (folder / "quits.py").write_text("import os\n\ndef solve(T, q):\n    os._exit(3)\n")
    (folder / "syntax.py").write_text("def solve(T, q)\n    return q\n")
    (folder / "BOB.PY").write_text(src)
    options = ["--cases", "3", "--cycles", "1", "--seed", "2", "--workers", "2"]
    cli_path = tmp_path / "cli.json"
    assert main(["grade", str(folder), *options, "--report", str(cli_path)]) == 1
    cli_out = capsys.readouterr().out
    with caplog.at_level("INFO", logger="kr210_sim.api"):
        report = kr210_sim.grade(folder, cases=3, cycles=1, seed=2, workers=2)
    assert isinstance(report, kr210_sim.GradeReport) and report.path is None
    from_cli = json.loads(cli_path.read_text())
    assert _timeless(report.to_dict()) == _timeless(from_cli)
    assert dict(report.verdicts) == {
        "correct": "pass",
        "no_offset": "fail",
        "quits": "crashed",
        "syntax": "error",
        "BOB.PY": "error",
    }
    assert [s["name"] for s in report.students] == [s["name"] for s in from_cli["students"]]

    def untimed(text: str) -> str:
        return re.sub(r"\b\d+\.\d\b", "T", text)

    assert not report.passed and untimed(report.text) in untimed(cli_out)
    assert sorted(r.getMessage().split()[1] for r in caplog.records) == sorted(report.verdicts)
    with pytest.raises(TypeError):
        report.students[0]["verdict"] = "pass"  # type: ignore[index]


def test_grade_refuses_bad_arguments_in_one_line(tmp_path: Path) -> None:
    for kwargs, why in (
        ({"submissions": tmp_path / "nope.py"}, "nope.py: no such file"),
        ({"submissions": 3}, "submissions must be a list of paths or SPECs"),
        ({"submissions": []}, "no submission"),
        ({"submissions": [str(tmp_path), 3]}, "a submission must be a path or a SPEC"),
        ({"submissions": "x.py:solve", "cases": 2_000_000}, "--cases must be a whole number"),
        ({"submissions": "x.py:solve", "cycles": True}, "cycles must be a whole number >= 1"),
        ({"submissions": "x.py:solve", "timeout": -1.0}, "--timeout and --ik-timeout"),
    ):
        with pytest.raises(ConfigError) as info:
            kr210_sim.grade(**kwargs)  # type: ignore[arg-type]
        assert why in str(info.value) and len(str(info.value).splitlines()) == 1
