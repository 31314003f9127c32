"""``grade``: a class of submissions, each in its own sandbox, one leaderboard (eval/grade.py).

The class below has one submission per way student code goes wrong (a hang, ``os._exit``,
``sys.exit``, a memory hog, a syntax error, 10 MB of prints), a correct one and one with the
classic 0.054 m mistake; it is graded in one call of the real command.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from kr210_sim.cli import main
from kr210_sim.errors import ConfigError
from kr210_sim.eval.grade import Student, find_students

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "ik_dh.py"

BAD = {
    "hang": "def solve(T, q):\n    while True:\n        pass\n",
    "quits": "import os\n\ndef solve(T, q):\n    os._exit(3)\n",
    "exits": "import sys\n\ndef solve(T, q):\n    sys.exit(4)\n",
    "hog": "def solve(T, q):\n    keep = [bytearray(8 << 30)]\n    return keep\n",
    "syntax": "def solve(T, q)\n    return q\n",
    "chatty": (
        "from correct import solve as _solve\n_said = []\n\n"
        "def solve(T, q):\n    if not _said:\n        _said.append(1)\n"
        "        for _ in range(10_000):\n            print('x' * 1023)\n"
        "    return _solve(T, q)\n"
    ),
}
EXPECTED = {
    "correct": "pass",
    "chatty": "pass",
    "no_offset": "fail",
    "hang": "timeout",
    "quits": "crashed",
    "exits": "crashed",
    "hog": "crashed",
    "syntax": "error",
}


def make_class(folder: Path) -> Path:
    """The test class: one .py file per student."""
    folder.mkdir(parents=True)
    src = EXAMPLE.read_text()
    (folder / "correct.py").write_text(src)
    (folder / "no_offset.py").write_text(src.replace("\nA3 = -0.054", "\nA3 = 0.0"))
    for name, body in BAD.items():
        (folder / f"{name}.py").write_text(body)
    return folder


def _tree(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def _ours_running(marker: str) -> list[str]:
    """Command lines of live processes that name ``marker`` (a test's tmp folder)."""
    found = []
    for pid in os.listdir("/proc"):
        if not pid.isdigit() or int(pid) == os.getpid():
            continue
        try:
            cmd = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(") ", 1)[1][0]
        except (OSError, IndexError):
            continue
        if marker in cmd and state != "Z":
            found.append(cmd)
    return found


def _grade(args: list[str], cwd: Path, tmp: Path) -> subprocess.Popen[str]:
    env = dict(os.environ, TMPDIR=str(tmp), PYTHONPATH=str(ROOT))
    return subprocess.Popen(
        [sys.executable, "-m", "kr210_sim", "grade", *args],
        cwd=cwd,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


@pytest.mark.slow
def test_a_class_of_bad_submissions_is_graded_in_one_call(tmp_path: Path) -> None:
    folder = make_class(tmp_path / "class")
    before = _tree(folder)
    cwd, tmp, out = tmp_path / "cwd", tmp_path / "tmp", tmp_path / "out"
    for d in (cwd, tmp, out):
        d.mkdir()
    args = ["../class", "--cases", "20", "--cycles", "2", "--ik-timeout", "1", "--workers", "2"]
    args += ["--report", str(out / "grade.json"), "--html", str(out / "grade.html")]
    proc = _grade(args, cwd, tmp)
    stdout, stderr = proc.communicate(timeout=900)
    assert proc.returncode == 1, stderr
    assert "Traceback" not in stdout + stderr
    report = json.loads((out / "grade.json").read_text())
    by_name = {s["name"]: s for s in report["students"]}
    assert {n: s["verdict"] for n, s in by_name.items()} == EXPECTED
    assert [s["verdict"] for s in report["students"][:3]] == ["pass", "pass", "fail"]
    assert report["summary"]["verdicts"] == {
        "pass": 2,
        "fail": 1,
        "timeout": 1,
        "crashed": 3,
        "error": 1,
    }
    first = "(ik-check case 1 of 88: IK_debug case 1)"
    assert by_name["hang"]["detail"] == f"no answer within 1 s {first}"
    assert by_name["quits"]["detail"] == f"the IK process exited with code 3 during a call {first}"
    assert by_name["exits"]["detail"] == f"called sys.exit(4) during a call {first}"
    assert by_name["hog"]["detail"] == f"ran out of memory during a call (limit 1024 MB) {first}"
    assert by_name["syntax"]["detail"] == (
        "--ik '../class/syntax.py:solve': syntax error in ../class/syntax.py line 1: expected ':'"
    )
    ok = by_name["correct"]
    assert ok["ik_check"]["passed"] == ok["ik_check"]["cases"] == 88  # 68 fixed + 20 random
    assert ok["ik_check"]["max_position_error_m"] < 1e-9
    assert ok["run"]["successes"] == 2
    wrong = by_name["no_offset"]
    assert wrong["ik_check"]["passed"] == 0
    assert abs(wrong["ik_check"]["max_position_error_m"] - 0.054) < 1e-6
    assert wrong["diagnosis"][0]["code"] == "offset_0054"
    assert wrong["run"]["successes"] == 0
    assert wrong["run"]["failed_cycles"][0]["replay"] == (
        "python -m kr210_sim run --ik ../class/no_offset.py:solve --ik-timeout 1 --cycles 1 "
        "--seed 0 --video videos/no_offset_cycle1.mp4"
    )
    chatty = by_name["chatty"]["output"]
    assert chatty["bytes"] == 10_000 * 1024
    assert len(chatty["stdout"]) < 40_000 and "bytes left out" in chatty["stdout"]
    # The terminal table, a line per student in the report's order.
    lines = [ln for ln in stdout.splitlines() if ln[:5].strip().isdigit()]
    assert [ln.split()[1] for ln in lines] == [s["name"] for s in report["students"]]
    assert "FAIL: 6 students did not pass" in stdout
    page = (out / "grade.html").read_text()
    assert page.count("data:image/png;base64,") == 2 * 3  # two plots per ik-checked student
    assert "http://" not in page and "https://" not in page and "<script" not in page
    # Nothing left running, nothing written but the report, the page and the scratch folders.
    assert _ours_running(str(tmp_path)) == []
    assert _tree(folder) == before
    assert _tree(tmp) == [] and _tree(cwd) == []
    assert _tree(out) == ["grade.html", "grade.json"]


@pytest.mark.slow
def test_sigterm_keeps_the_students_finished_and_leaves_nothing_running(tmp_path: Path) -> None:
    folder = make_class(tmp_path / "class")
    cwd, tmp = tmp_path / "cwd", tmp_path / "tmp"
    cwd.mkdir()
    tmp.mkdir()
    report = tmp_path / "grade.json"
    args = [str(folder / "correct.py"), str(folder / "hang.py"), "--workers", "2"]
    args += ["--cases", "0", "--cycles", "1", "--ik-timeout", "600", "--report", str(report)]
    proc = _grade(args, cwd, tmp)
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()  # the first student finished: the correct one
        assert "correct" in line and " pass " in line, line
        time.sleep(0.5)
        proc.send_signal(signal.SIGTERM)
        _, stderr = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == 143, stderr
    assert "interrupted (SIGTERM) after 1 of 2 students" in stderr
    assert "Traceback" not in stderr
    data = json.loads(report.read_text())
    assert data["interrupted_by"] == "SIGTERM"
    assert [(s["name"], s["verdict"]) for s in data["students"]] == [("correct", "pass")]
    assert _ours_running(str(tmp_path)) == []
    assert _tree(tmp) == []


@pytest.mark.slow
def test_exit_0_when_every_student_passes(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    report = tmp_path / "grade.json"
    argv = ["grade", f"{EXAMPLE}:solve", "--cases", "0", "--cycles", "1", "--workers", "1"]
    assert main([*argv, "--report", str(report)]) == 0
    assert "PASS: all 1 students passed" in capsys.readouterr().out
    assert json.loads(report.read_text())["students"][0]["name"] == "ik_dh"


def test_usage_errors_are_one_line_and_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    empty = tmp_path / "empty"
    empty.mkdir()
    for argv, message in (
        ([str(tmp_path / "nope.py")], "nope.py: no such file"),
        ([str(empty)], "no student in this folder"),
        ([str(tmp_path / "x.txt")], "not a folder, a .py file or a SPEC"),
        ([f"{EXAMPLE}:solve", "--memory", "100"], "--memory must be at least 256 MB"),
        ([f"{EXAMPLE}:solve", "--report", str(tmp_path)], "is a folder"),
    ):
        assert main(["grade", *argv]) == 2
        err = capsys.readouterr().err
        assert message in err and len(err.strip().splitlines()) == 1, err
    for argv in (["grade"], ["grade", str(EXAMPLE), "--timeout", "0"]):
        with pytest.raises(SystemExit) as info:
            main(argv)
        assert info.value.code == 2


def test_submissions_resolve_to_named_students(tmp_path: Path) -> None:
    (tmp_path / "alice.py").write_text("def solve(T, q): return q\n")
    (tmp_path / "_helper.py").write_text("")
    bob = tmp_path / "bob"
    bob.mkdir()
    (bob / "ik.py").write_text("")
    (bob / "util.py").write_text("")
    carol = tmp_path / "carol"
    carol.mkdir()
    (carol / "my_solution.py").write_text("")
    dave = tmp_path / "dave"
    dave.mkdir()
    (dave / "a.py").write_text("")
    (dave / "b.py").write_text("")
    (tmp_path / ".hidden").mkdir()
    (tmp_path / "notes.txt").write_text("")
    found = find_students([str(tmp_path), f"{EXAMPLE}:nearest"])
    assert found == [
        Student("alice", f"{tmp_path}/alice.py:solve"),
        Student("bob", f"{bob}/ik.py:solve"),
        Student("carol", f"{carol}/my_solution.py:solve"),
        Student("dave", "", f"no ik.py in {dave} (2 .py files)"),
        Student("ik_dh", f"{EXAMPLE}:nearest"),
    ]
    with pytest.raises(ConfigError, match="two students named 'alice'"):
        find_students([str(tmp_path), str(tmp_path / "alice.py")])
