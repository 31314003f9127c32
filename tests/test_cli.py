"""The command line: usage errors are one line with exit 2; a run writes its report."""

from __future__ import annotations

import ctypes.util
import json
import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from kr210_sim import __version__
from kr210_sim.cli import main
from kr210_sim.score.report import strip_wall
from kr210_sim.util.paths import SCENES_DIR


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["run", "--cycles", "0"], "must be at least 1"),
        (["run", "--cycles", "-3"], "must be at least 1"),
        (["run", "--cycles", "abc"], "expected a whole number"),
        (["run", "--slot", "26"], "at most 25"),
        (["run", "--min-success", "1.5"], "must be in [0, 1]"),
        (["run", "--seed", "-1"], "must be >= 0"),
        (["fly"], "invalid choice"),
        ([], "required"),
    ],
)
def test_usage_errors(argv: list[str], message: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert message in err
    assert len(err.strip().splitlines()) == 1
    assert "Traceback" not in err


COMMANDS = (
    "run", "replay", "view", "evaluate", "check", "ik-check", "grade", "demos",
    "build-scene", "build-meshes", "snapshot", "perceive", "train-recogniser",
)  # fmt: skip


def test_commands_and_their_help(capsys: pytest.CaptureFixture[str]) -> None:
    """The parser lists these commands in this order; each one's --help exits 0 and every
    option it shows has a help text."""
    import argparse

    from kr210_sim.cli import build_parser

    (sub,) = [a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction)]
    assert tuple(sub.choices) == COMMANDS
    for name in COMMANDS:
        with pytest.raises(SystemExit) as exc:
            main([name, "--help"])
        assert exc.value.code == 0
        assert capsys.readouterr().out.startswith(f"usage: kr210_sim {name} ")
        command = sub.choices[name]
        assert all(a.help for a in command._actions), name


@pytest.mark.parametrize("argv", [["run", "--cycles", "0"], ["check", "--help"], ["fly"]])
def test_main_leaves_the_signal_handlers_as_it_found_them(argv: list[str]) -> None:
    """main() holds the signals from its first line (the start-up): a usage error, --help or
    a command's end puts the handlers back, in a process that goes on (a test, a notebook)."""
    import signal

    from kr210_sim.util.interrupts import SIGNALS

    before = {s: signal.getsignal(s) for s in SIGNALS}
    with pytest.raises(SystemExit):
        main(argv)
    assert {s: signal.getsignal(s) for s in SIGNALS} == before


def test_unwritable_report(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("")
    code = main(["run", "--cycles", "1", "--report", str(blocker / "run.json")])
    assert code == 2
    err = capsys.readouterr().err
    assert err.startswith("kr210_sim: error: ") and len(err.strip().splitlines()) == 1


def test_report_is_a_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", "--cycles", "1", "--report", str(tmp_path)]) == 2
    assert "is a folder" in capsys.readouterr().err


def test_version() -> None:
    """One version: pyproject.toml's, as the installed metadata and ``__version__`` give it."""
    import tomllib
    from importlib.metadata import version

    pyproject = tomllib.loads((Path(__file__).parents[1] / "pyproject.toml").read_text())
    assert __version__ == version("kr210_sim") == pyproject["project"]["version"]
    out = subprocess.run(
        [sys.executable, "-m", "kr210_sim", "--version"], capture_output=True, text=True, check=True
    ).stdout
    import mujoco

    from kr210_sim.robot import ik_scalar

    first, platform, ik = out.splitlines()
    assert first == f"kr210_sim {pyproject['project']['version']}"
    assert platform.startswith(f"MuJoCo {mujoco.__version__}, numpy ")
    path = "compiled" if ik_scalar.NATIVE else "pure Python"
    assert ik.startswith(f"inverse kinematics of one pose: {path}")


def test_version_says_when_the_ik_is_pure_python() -> None:
    env = {**os.environ, "KR210_SIM_PURE_IK": "1"}
    out = subprocess.run(
        [sys.executable, "-m", "kr210_sim", "--version"],
        capture_output=True, text=True, check=True, env=env,
    ).stdout  # fmt: skip
    assert out.splitlines()[-1] == (
        "inverse kinematics of one pose: pure Python (KR210_SIM_PURE_IK is set)"
    )


def test_run_writes_report(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    report = tmp_path / "sub" / "run.json"
    code = main(["run", "--cycles", "1", "--slot", "2", "--seed", "3", "--report", str(report)])
    assert code == 0
    out = capsys.readouterr().out
    assert "[1/1] slot 2  ok" in out and "PASS: 1/1" in out
    data = json.loads(report.read_text())
    (cycle,) = data["cycles"]
    assert cycle["success"] is True and cycle["reason"] is None and cycle["slot"] == 2
    s = data["summary"]
    assert (s["cycles"], s["successes"], s["success_rate"]) == (1, 1, 1.0)
    assert data["config"]["seed"] == 3
    assert set(data["versions"]) >= {"kr210_sim", "mujoco", "numpy", "ruckig", "python", "ompl"}
    assert not list(report.parent.glob("*.tmp"))


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["evaluate", "--workers", "0"], "must be at least 1"),
        (["evaluate", "--episodes", "0"], "must be at least 1"),
        (["evaluate", "--episodes", "x"], "expected a whole number"),
        (["evaluate", "--min-success", "2"], "must be in [0, 1]"),
    ],
)
def test_evaluate_usage_errors(
    argv: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1


def _one_line(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    return err


@pytest.mark.parametrize("command", ["run", "evaluate"])
def test_missing_scene(tmp_path: Path, command: str, capsys: pytest.CaptureFixture[str]) -> None:
    argv = [command, "--scene", str(tmp_path / "nope.xml"), "--report", str(tmp_path / "r.json")]
    assert main(argv) == 2
    assert "scene not found" in _one_line(capsys)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("<mujoco><worldbody><body></mujoco>", "MuJoCo cannot load scene"),
        ("<mujoco><worldbody/></mujoco>", "is not a kr210_sim cell"),
    ],
)
def test_malformed_scene(
    tmp_path: Path, text: str, message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    scene = tmp_path / "bad.xml"
    scene.write_text(text)
    argv = ["run", "--cycles", "1", "--scene", str(scene), "--report", str(tmp_path / "r.json")]
    assert main(argv) == 2
    assert message in _one_line(capsys)


@pytest.mark.parametrize("command", ["run", "evaluate", "check"])
def test_a_cell_file_given_as_scene_points_to_cell(
    tmp_path: Path, command: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """A cell file is not MJCF: ``--scene x.toml`` says to use ``--cell``, not "XML parse error"."""
    cell = SCENES_DIR / "cells" / "column.toml"
    argv = [command, "--scene", str(cell)]
    if command != "check":
        argv += ["--report", str(tmp_path / "r.json")]
    assert main(argv) == 2
    err = _one_line(capsys)
    assert f"scene {cell} is a cell file, not MJCF: give it with --cell" in err
    assert "XML" not in err


def _run_with_root(root: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "KR210_SIM_ROOT": str(root)}
    return subprocess.run(
        [sys.executable, "-m", "kr210_sim", "run", "--cycles", "1", "--report",
         str(root / "r.json")],
        capture_output=True, text=True, env=env, check=False,
    )  # fmt: skip


@pytest.mark.parametrize(
    ("urdf", "message"), [(None, "URDF not found"), ("<robot name='x'><link", "malformed")]
)
def test_missing_or_malformed_urdf(tmp_path: Path, urdf: str | None, message: str) -> None:

    (tmp_path / "assets" / "kr210").mkdir(parents=True)
    (tmp_path / "scenes").symlink_to(SCENES_DIR)
    if urdf is not None:
        (tmp_path / "assets" / "kr210" / "kr210.urdf").write_text(urdf)
    proc = _run_with_root(tmp_path)
    assert proc.returncode == 2
    assert message in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and "Traceback" not in proc.stderr


def test_ctrl_c_during_a_run_writes_the_cycles_done(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    ctrl_c_on_call: Callable[[Callable[..., Any], int], Callable[..., Any]],
) -> None:
    from kr210_sim.sim.runner import Runner

    monkeypatch.setattr(Runner, "run_cycle", ctrl_c_on_call(Runner.run_cycle, 3))
    report = tmp_path / "run.json"
    assert main(["run", "--cycles", "5", "--report", str(report)]) == 130
    data = json.loads(report.read_text())
    assert data["interrupted"] is True
    assert [c["index"] for c in data["cycles"]] == [1, 2]
    assert data["summary"]["cycles"] == 2
    assert "interrupted after 2 cycles" in capsys.readouterr().err


def test_same_command_twice_gives_identical_json(tmp_path: Path) -> None:
    texts = []
    for name in ("a.json", "b.json"):
        path = tmp_path / name
        argv = ["run", "--cycles", "3", "--seed", "11", "--randomize", "--report", str(path)]
        assert main(argv) == 0
        texts.append(json.dumps(strip_wall(json.loads(path.read_text())), indent=2, sort_keys=True))
    assert texts[0] == texts[1]


def test_absurd_cycle_counts_are_refused(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["run", "--cycles", "100000000000000000000"])
    assert exc.value.code == 2
    assert "at most 10000 in one run (use evaluate)" in _one_line(capsys)


@pytest.mark.parametrize(
    ("outputs", "message"),
    [
        (["--report", "{d}/x.mp4", "--video", "{d}/x.mp4"], "--video and --report name the same"),
        (["--report", "{d}/p/cycle_times.png", "--plots", "{d}/p"], "--report name the same"),
        (["--report", "{d}/scene.xml", "--scene", "{d}/scene.xml"], "--report and --scene"),
        (["--report", "{scene}"], "kr210_cell.xml is one of kr210_sim's own files"),
    ],
)
def test_clashing_outputs_are_refused_before_anything_runs(
    tmp_path: Path, outputs: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    from kr210_sim.util.paths import SCENE_PATH

    scene_text = SCENE_PATH.read_text()
    (tmp_path / "scene.xml").write_text(scene_text)
    argv = [a.format(d=tmp_path, scene=SCENE_PATH) for a in outputs]
    assert main(["run", "--cycles", "1", *argv]) == 2
    assert message in _one_line(capsys)
    assert (tmp_path / "scene.xml").read_text() == scene_text
    assert SCENE_PATH.read_text() == scene_text
    assert not (tmp_path / "x.mp4").exists() and not (tmp_path / "p" / "cycle_times.png").exists()


def test_a_plot_folder_that_cannot_be_made_is_refused_up_front(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("")
    report = tmp_path / "r.json"
    argv = ["run", "--cycles", "1", "--report", str(report), "--plots", str(blocker / "plots")]
    assert main(argv) == 2
    assert "cannot create the folder" in _one_line(capsys)
    assert not report.exists()  # refused before any cycle ran


def test_a_plot_name_taken_by_a_folder_is_refused_up_front(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "plots" / "gripper_error.png").mkdir(parents=True)
    report = tmp_path / "r.json"
    argv = ["run", "--cycles", "1", "--report", str(report), "--plots", str(tmp_path / "plots")]
    assert main(argv) == 2
    assert "gripper_error.png is a folder" in _one_line(capsys)
    assert not report.exists()


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes through any permission bits")
def test_a_read_only_plot_folder_is_refused_up_front(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    plots = tmp_path / "plots"
    plots.mkdir()
    plots.chmod(0o500)
    report = tmp_path / "r.json"
    argv = ["run", "--cycles", "1", "--report", str(report), "--plots", str(plots)]
    assert main(argv) == 2
    assert "permission denied" in _one_line(capsys)
    assert not report.exists()


def test_long_runs_keep_no_per_tick_recordings(tmp_path: Path) -> None:
    from kr210_sim.jobs import run_job
    from kr210_sim.sim.runner import RunConfig, Runner

    runner = Runner(RunConfig(cycles=2, seed=1))
    for i in (1, 2):
        runner.run_cycle(i, 5)
    assert runner.recordings == []  # bounded memory without --plots
    job = run_job(RunConfig(cycles=1, slot=5), tmp_path / "r.json", plots_dir=tmp_path / "p")
    assert [p.name for p in job.plot_paths] == [
        "tracking_error.png",
        "gripper_error.png",
        "joint_limits.png",
        "cycle_times.png",
    ]


def test_empty_gl_variable_counts_as_unset() -> None:
    """``MUJOCO_GL=`` (set but empty) is no backend's name: the default (egl without a display)
    is chosen, and rendering works."""
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "PYOPENGL_PLATFORM")}
    probe = "import os; from kr210_sim.util import gl; "
    probe += "print(os.environ['MUJOCO_GL'], gl.GL_IMPORT_ERROR)"
    proc = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True,
        env={**env, "MUJOCO_GL": ""}, check=False,
    )  # fmt: skip
    assert proc.stdout == "egl None\n", proc.stderr


def test_empty_root_variable_counts_as_unset(tmp_path: Path) -> None:
    """``KR210_SIM_ROOT=`` (set but empty) is not the current folder."""
    env = {**os.environ, "KR210_SIM_ROOT": ""}
    proc = subprocess.run(
        [sys.executable, "-m", "kr210_sim", "run", "--cycles", "1"],
        cwd=tmp_path, capture_output=True, text=True, env=env, check=False,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "reports" / "run.json").is_file()


def test_scene_naming_a_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", "--cycles", "1", "--scene", str(tmp_path)]) == 2
    err = _one_line(capsys)
    assert f"scene {tmp_path} is a folder" in err and "build-scene" not in err


def _blocked_outputs(tmp_path: Path) -> dict[str, Path]:
    """Output paths that cannot be written, even by root."""
    afile = tmp_path / "afile"
    afile.write_text("")
    taken = tmp_path / "taken"
    (taken / "kr210_cell.xml").mkdir(parents=True)
    (taken / "base_link.stl").mkdir()
    return {"a file": afile, "under a file": afile / "sub", "target is a folder": taken}


@pytest.mark.parametrize("command", ["build-scene", "build-meshes"])
@pytest.mark.parametrize("case", ["a file", "under a file", "target is a folder"])
def test_build_into_an_unwritable_out(
    tmp_path: Path, command: str, case: str, capsys: pytest.CaptureFixture[str]
) -> None:
    out = _blocked_outputs(tmp_path)[case]
    assert main([command, "--out", str(out)]) == 2
    assert str(out) in _one_line(capsys)
    assert not list(tmp_path.rglob("*.tmp"))


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
@pytest.mark.parametrize("command", ["build-scene", "build-meshes"])
def test_build_into_a_read_only_folder(
    tmp_path: Path, command: str, capsys: pytest.CaptureFixture[str]
) -> None:
    tmp_path.chmod(0o500)
    try:
        assert main([command, "--out", str(tmp_path / "out")]) == 2
    finally:
        tmp_path.chmod(0o700)
    assert "cannot create the folder" in _one_line(capsys)


def _without_gl_backend(gl: str) -> dict[str, str]:
    return {**os.environ, "MUJOCO_GL": gl, "PYOPENGL_PLATFORM": ""}


_BAD_GL = ["nonsense"] + (["osmesa"] if ctypes.util.find_library("OSMesa") is None else [])


@pytest.mark.parametrize("gl", _BAD_GL)
def test_a_bad_gl_backend_stops_only_rendering(tmp_path: Path, gl: str) -> None:
    """MUJOCO_GL naming no backend (or one whose library is missing) does not stop the physics;
    rendering then fails with one line naming MUJOCO_GL and what to install."""
    env = _without_gl_backend(gl)
    kr210 = [sys.executable, "-m", "kr210_sim"]
    run = subprocess.run(
        [*kr210, "run", "--cycles", "1", "--report", str(tmp_path / "r.json")],
        capture_output=True, text=True, env=env, check=False,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    assert "PASS: 1/1" in run.stdout and not run.stderr
    snap = subprocess.run(
        [*kr210, "snapshot", "--out", str(tmp_path / "s.png")],
        capture_output=True, text=True, env=env, check=False,
    )  # fmt: skip
    assert snap.returncode == 2
    (line,) = snap.stderr.strip().splitlines()
    assert line.startswith("kr210_sim: error: no OpenGL backend") and "Traceback" not in line
    assert f"MUJOCO_GL={gl}" in line and "apt-get install libegl1" in line
    assert not (tmp_path / "s.png").exists()


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["snapshot", "--out", "{scene}"], "is one of kr210_sim's own files"),
        (["snapshot", "--out", "{d}/mine.toml", "--cell", "{d}/mine.toml"], "--out and --cell"),
        (["snapshot", "--out", "{d}/x.jpg"], "snapshot writes a PNG; give a path ending in .png"),
        (
            ["ik-check", "--ik", "{d}/my_ik.py:solve", "--report", "{d}/my_ik.py"],
            "--report and --ik",
        ),
        (["ik-check", "--ik", "{d}/my_ik.py:solve", "--report", "{kin}"], "kr210_sim's own files"),
        (["evaluate", "--report", "{urdf}"], "is one of kr210_sim's own files"),
        (["demos", "--out", "{urdf}"], "is one of kr210_sim's own files"),
    ],
)
def test_no_command_writes_over_an_input(
    tmp_path: Path, argv: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    from kr210_sim.cell.toml import PUBLISHED_CELL
    from kr210_sim.util.paths import PACKAGE_DIR, SCENE_PATH, URDF_PATH

    mine = tmp_path / "mine.toml"
    mine.write_text(PUBLISHED_CELL.read_text())
    user = tmp_path / "my_ik.py"
    user.write_text("from kr210_sim.robot.kinematics import nearest as solve\n")
    kin = PACKAGE_DIR / "robot" / "kinematics.py"
    inputs = {p: p.read_bytes() for p in (mine, user, kin, SCENE_PATH, URDF_PATH)}
    names = {"d": tmp_path, "scene": SCENE_PATH, "urdf": URDF_PATH, "kin": kin}
    assert main([a.format(**names) for a in argv]) == 2
    assert message in _one_line(capsys)
    assert all(p.read_bytes() == data for p, data in inputs.items())
    assert not (tmp_path / "x.jpg").exists()


def test_the_report_may_not_overwrite_the_ik_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from kr210_sim.util.paths import ROOT

    user = tmp_path / "my_ik.py"
    user.write_text((ROOT / "examples" / "ik_dh.py").read_text())
    text = user.read_text()
    assert main(["run", "--cycles", "1", "--ik", f"{user}:solve", "--report", str(user)]) == 2
    assert "--report and --ik name the same file" in _one_line(capsys)
    assert user.read_text() == text


def test_messages_that_said_the_wrong_thing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from kr210_sim.commands import _duration
    from kr210_sim.score.report import summary_table

    # A run slower than real time read "0x real time".
    summary = {**json.loads(_run_report(tmp_path))["summary"], "wall_real_time_factor": 0.04}
    assert "(0.04x real time)" in summary_table(summary)
    # A slow IK read "30003057.0 us mean" for 30 s.
    assert [_duration(t) for t in (2.5e-5, 0.0123, 30.003057)] == ["25.0 us", "12.3 ms", "30.00 s"]
    # --host that is no address read "port busy"; --replay with --joints was silently ignored.
    assert main(["view", "--host", "256.1.1.1", "--report", str(tmp_path / "v.json")]) == 2
    assert "--host 256.1.1.1: not an IP address" in _one_line(capsys)
    assert main(["view", "--joints", "--replay", str(tmp_path / "r.npz")]) == 2
    assert "--replay plays a recording: drop one" in _one_line(capsys)


def _run_report(tmp_path: Path) -> str:
    report = tmp_path / "run.json"
    assert main(["run", "--cycles", "1", "--slot", "5", "--report", str(report)]) == 0
    return report.read_text()
