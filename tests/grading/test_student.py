"""One student's grading (grading/student.py): the student's own time, the sandbox it gets, and
the film-it command, which must run as printed."""

from __future__ import annotations

import dataclasses
import os
import shlex
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from kr210_sim.cli import build_parser
from kr210_sim.errors import ConfigError
from kr210_sim.grading.roster import find_students
from kr210_sim.grading.student import (
    StudentClock,
    StudentJob,
    _verdict,
    grade_student,
    one_branch,
    replay_command,
    shell_word,
    student_sandbox,
    video_name,
)
from kr210_sim.robot import kinematics
from kr210_sim.sandbox.guarded import load_user_ik
from kr210_sim.sandbox.ik_sandbox import SandboxStop
from kr210_sim.sandbox.user_ik import spec_root

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "ik_dh.py"
Q = np.array([0.3, 0.2, -0.3, 0.5, 0.6, -0.4])


def _job(tmp_path: Path, spec: str, name: str = "amy", timeout: float = 60.0) -> StudentJob:
    return StudentJob(
        name=name,
        spec=spec,
        problem="",
        cases=0,
        cycles=1,
        seed=3,
        timeout=timeout,
        ik_timeout=60.0,
        memory_mb=1024,
        min_success=0.8,
        scratch=str(tmp_path / "scratch"),
    )


def test_our_time_between_calls_does_not_count_against_the_student(tmp_path: Path) -> None:
    """``--timeout`` was a wall-clock deadline over the whole student: our simulation used it
    up and a correct student was ``timeout``."""
    sandbox = student_sandbox(_job(tmp_path, f"{EXAMPLE}:solve"))
    clock = StudentClock(sandbox, budget=60.0)
    try:
        clock.start()
        assert clock.calls == 0 and clock.import_time > 0
        clock.budget = clock.used + 1.0  # one more second of the student's own time
        T = kinematics.forward(Q)
        for _ in range(3):
            time.sleep(0.6)  # our own work between its calls: 1.8 s in all
            np.testing.assert_allclose(clock(T, Q), Q, atol=1e-9)
        assert clock.calls == 3 and not clock.spent
        assert clock.call_time < 1.0  # three answers, not the 1.8 s between them
    finally:
        sandbox.close()


def test_the_call_that_uses_the_budget_up_is_cut_there(tmp_path: Path) -> None:
    path = tmp_path / "slow.py"
    path.write_text(
        textwrap.dedent(
            """
            import time

            def solve(T, q):
                time.sleep(600)
            """
        )
    )
    sandbox = student_sandbox(_job(tmp_path, f"{path}:solve"))  # 60 s per call
    clock = StudentClock(sandbox, budget=60.0)
    try:
        clock.start()
        clock.budget = clock.used + 0.5
        with pytest.raises(SandboxStop) as info:
            clock(kinematics.forward(Q), Q)
        assert info.value.verdict == "timeout" and clock.spent
        assert clock.spent_detail().startswith(
            f"its code took longer than --timeout ({clock.budget:g} s) in all: "
        )
        assert clock.spent_detail().endswith("s in 1 calls")
    finally:
        sandbox.close()


def test_the_import_may_take_the_whole_budget(tmp_path: Path) -> None:
    """The import had a hidden limit of its own (30 s), whatever --timeout said."""
    box = student_sandbox(_job(tmp_path, f"{EXAMPLE}:solve", timeout=300.0))
    assert box.limits.load_timeout == 300.0
    assert box.limits.call_timeout == 60.0 and box.limits.memory_mb == 1024 and box.stop
    box.close()
    clock = StudentClock(box, budget=300.0)
    assert clock.spent_detail() == "importing it took longer than --timeout (300 s)"


def _parsed(command: str) -> object:
    argv = shlex.split(command)
    assert argv[:3] == ["python", "-m", "kr210_sim"]
    return build_parser().parse_args(argv[3:])


def test_the_film_it_command_runs_as_printed_for_a_file_named_like_an_option(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "--x.py").write_text("")
    (student,) = find_students(["--x.py"])
    command = replay_command(_job(tmp_path, student.spec, student.name), 4)
    args = _parsed(command)
    assert args.command == "run" and args.ik == "./--x.py:solve"  # type: ignore[attr-defined]
    assert (args.cycles, args.seed, args.ik_timeout) == (4, 3, 60.0)  # type: ignore[attr-defined]
    assert str(args.video) == "videos/--x_cycle4.mp4"  # type: ignore[attr-defined]
    assert Path(args.ik.rpartition(":")[0]).is_file()  # type: ignore[attr-defined]


@pytest.mark.slow
def test_the_film_it_command_shows_a_folder_student_its_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A folder student whose ik.py imports a module beside it: grade's jail shows it the
    folder, and so does the command grade prints to film its run (``--ik-root``); a file SPEC
    alone shows the file alone (REDTEAM-4 row 8), where the import fails."""
    monkeypatch.chdir(tmp_path)
    folder = tmp_path / "class" / "carol"
    folder.mkdir(parents=True)
    (folder / "dh.py").write_text(EXAMPLE.read_text())
    (folder / "ik.py").write_text("from dh import solve\n")
    (student,) = find_students(["class"])
    job = dataclasses.replace(_job(tmp_path, student.spec, student.name), root=student.root)
    argv = shlex.split(replay_command(job, 1))[3:]
    assert argv[argv.index("--ik-root") + 1] == "class/carol"
    argv = argv[: argv.index("--video")]  # the run, not its film
    filmed = subprocess.run(
        [sys.executable, "-m", "kr210_sim", *argv], capture_output=True, text=True, timeout=300
    )
    assert filmed.returncode == 0, filmed.stderr
    assert "PASS: 1/1 cycles" in filmed.stdout
    i = argv.index("--ik-root")
    alone = subprocess.run(
        [sys.executable, "-m", "kr210_sim", *argv[:i], *argv[i + 2 :]],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert alone.returncode == 2 and "No module named 'dh'" in alone.stderr, alone.stderr


def test_ik_root_is_checked_before_anything_runs(tmp_path: Path) -> None:
    (tmp_path / "a").mkdir()
    (tmp_path / "a" / "ik.py").write_text("def solve(T, q):\n    return q\n")
    (tmp_path / "b").mkdir()
    (tmp_path / "link").symlink_to(tmp_path / "a")
    spec = f"{tmp_path / 'a' / 'ik.py'}:solve"
    assert spec_root(spec, tmp_path / "a") == (tmp_path / "a").resolve()
    assert spec_root(spec, tmp_path) == tmp_path.resolve()
    with pytest.raises(ConfigError, match="does not hold the SPEC's file"):
        spec_root(spec, tmp_path / "b")
    with pytest.raises(ConfigError, match="not a folder"):
        spec_root(spec, tmp_path / "link")
    with pytest.raises(ConfigError, match="needs a file SPEC"):
        spec_root("kr210_sim.robot.kinematics:nearest", tmp_path / "a")
    with pytest.raises(ConfigError, match="needs --ik-timeout"):
        load_user_ik(spec, None, root=(tmp_path / "a").resolve())


def test_the_film_it_command_names_the_same_file_whatever_its_bytes(tmp_path: Path) -> None:
    raw = b'it\'s \xff $(touch pwned) "q" \\ \n.py:solve'
    word = shell_word(os.fsdecode(raw))
    assert word.isascii() and word.isprintable()
    out = subprocess.run(
        ["bash", "-c", f"printf %s {word}"], cwd=tmp_path, capture_output=True, check=True
    )
    assert out.stdout == raw and not (tmp_path / "pwned").exists()
    assert shell_word("plain/ik.py:solve") == "plain/ik.py:solve"
    assert shell_word("a b.py:solve") == "'a b.py:solve'"
    long = "a" * 250
    assert video_name(long).startswith("a" * 55 + "_") and len(video_name(long)) == 64
    assert video_name("<script> x") == "_script__x" and video_name("no_offset") == "no_offset"
    command = replay_command(_job(tmp_path, f"c/{long}.py:solve", long), 1)
    assert len(Path(str(_parsed(command).video)).name) < 255  # type: ignore[attr-defined]


def _case(group: str, passed: bool, within: bool, pos: float, ori: float) -> dict[str, object]:
    return {
        "group": group,
        "passed": passed,
        "q": [0.0] * 6,
        "error": None,
        "within_limits": within,
        "position_error_m": pos,
        "orientation_error_rad": ori,
    }


def test_a_ros_server_is_not_failed_for_being_one_branch_outside_the_exercise_s_cases(
    tmp_path: Path,
) -> None:
    """The exercise's IK gives one branch: on a random or limit pose that only another branch
    reaches inside the limits, its answer reaches the pose outside them. A ROS-form server is
    not failed for that (it is told and counted); an answer that misses its pose, or any miss on
    IK_debug's or the cell's poses, still fails it; our form (given q_ref, asked for the nearest
    of all branches) is failed for every case."""
    assert one_branch(_case("random", False, False, 1e-12, 1e-12))
    assert one_branch(_case("limits", False, False, 9e-4, 9e-4))
    assert not one_branch(_case("cell", False, False, 1e-12, 1e-12))  # the exercise's own
    assert not one_branch(_case("ik_debug", False, False, 1e-12, 1e-12))
    assert not one_branch(_case("random", False, False, 1e-12, 0.0949))  # misses the pose
    assert not one_branch(_case("random", False, True, 1e-12, 1e-12))  # another problem
    assert not one_branch(_case("random", True, True, 0.0, 0.0))
    job = _job(tmp_path, "x.py:solve")
    run = {"successes": 1, "cycles_run": 1}
    ik = {"cases": 100, "cases_total": 100, "passed": 96, "one_branch": 4}
    verdict, detail = _verdict(job, ik, run, ros=True)
    assert verdict == "pass" and detail == (
        "ik-check 96/100 cases (4 more answers reach their pose outside the joint limits, where "
        "only another branch reaches it inside them: one branch, as the exercise's IK, not "
        "failed), run 1/1 cycles (pass bar 1)"
    )
    assert _verdict(job, ik, run)[0] == "fail"  # our form: every case counts
    assert _verdict(job, {**ik, "one_branch": 3}, run, ros=True)[0] == "fail"  # one more miss
    assert _verdict(job, ik, {"successes": 0, "cycles_run": 1}, ros=True)[0] == "fail"


def test_a_package_xml_too_large_to_read_is_the_student_s_error_in_one_line(
    tmp_path: Path,
) -> None:
    """A 3 GB sparse ``package.xml`` beside a ``msg`` folder: the grading process reads none
    of it, and the verdict says why (it was read whole, outside the jail)."""
    pkg = tmp_path / "repo" / "kuka_arm"
    (pkg / "msg").mkdir(parents=True)
    (pkg / "scripts").mkdir()
    with open(pkg / "package.xml", "wb") as f:
        f.truncate(3 << 30)
    server = pkg / "scripts" / "IK_server.py"
    server.write_text("import rospy\ndef handle_calculate_IK(req):\n    return None\n")
    record = grade_student(_job(tmp_path, f"{server}:handle_calculate_IK"))
    assert record["verdict"] == "error"
    assert record["detail"] == (
        f"{pkg / 'package.xml'} holds 3,221,225,472 bytes, more than the 1,048,576 read: "
        "not read (a package.xml is a few kB)"
    )
