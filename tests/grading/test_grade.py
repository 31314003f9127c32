"""``grade``: a class of submissions, each in its own sandbox, one leaderboard (grading/grade.py).

The first class below has one submission per way student code goes wrong (a hang, ``os._exit``,
``sys.exit``, a memory hog, a syntax error, 10 MB of prints), a correct one and one with the
classic 0.054 m mistake. The second is hostile: names made to break a shell, a terminal, a
page or the grader's temporary files, and submissions that forge their record or kill their
grading process. Each is graded in one call of the real command.
"""

from __future__ import annotations

import json
import os
import selectors
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from kr210_sim.cli import main
from kr210_sim.errors import ConfigError
from kr210_sim.grading import grade as grade_module
from kr210_sim.grading.grade import GradeSettings, relevant_line

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "ik_dh.py"

BAD = {
    "hang": "def solve(T, q):\n    while True:\n        pass\n",
    "quits": "import os\n\ndef solve(T, q):\n    os._exit(3)\n",
    "exits": "import sys\n\ndef solve(T, q):\n    sys.exit(4)\n",
    "hog": "def solve(T, q):\n    keep = [bytearray(8 << 30)]\n    return keep\n",
    "syntax": "def solve(T, q)\n    return q\n",
    "chatty": (  # our IK (make_class puts it first), then a first call that prints 10 MB
        "\n_solve = solve\n_said = []\n\n"
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
        (folder / f"{name}.py").write_text(src + body if name == "chatty" else body)
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
            cmd = (
                Path(f"/proc/{pid}/cmdline")
                .read_bytes()
                .replace(b"\0", b" ")
                .decode(errors="replace")
            )
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
    times = ok["wall_time_s"]
    assert 0 < times["student"] < times["total"]  # its own time: import and calls
    assert 0 <= times["held_off_cpu"] <= times["total"]  # not counted: held off the CPU
    assert ok["ik_check"]["max_position_error_m"] < 1e-9
    assert ok["run"]["successes"] == 2
    wrong = by_name["no_offset"]
    assert wrong["ik_check"]["passed"] == 0
    assert abs(wrong["ik_check"]["max_position_error_m"] - 0.054) < 1e-6
    assert wrong["diagnosis"][0]["code"] == "offset_0054"
    assert (wrong["run"]["successes"], wrong["run"]["cycles"]) == (0, 2)
    assert by_name["hang"]["run"] is None and by_name["hang"]["ik_check"] is None
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
def test_exit_0_when_every_student_passes(
    tmp_path: Path, capsys: pytest.CaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "mod_ik.py").write_text(EXAMPLE.read_text())  # a module SPEC, found here
    report = tmp_path / "grade.json"
    argv = ["grade", f"{EXAMPLE}:solve", "mod_ik:solve", "--cases", "0", "--cycles", "1"]
    assert main([*argv, "--workers", "2", "--report", str(report)]) == 0
    assert "PASS: all 2 students passed" in capsys.readouterr().out
    students = json.loads(report.read_text())["students"]
    assert sorted(s["name"] for s in students) == ["ik_dh", "mod_ik"]


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
        ([f"{tmp_path}/victim:solve"], f"{tmp_path}/victim is not a .py file"),
        (["..:solve"], "'..' is neither a .py file nor a module name"),
        ([str(EXAMPLE), "--cases", "99999999999999999999"], "--cases must be a whole number"),
        ([str(EXAMPLE), "--cases", "1000001"], "from 0 to 1,000,000, got 1000001"),
    ):
        assert main(["grade", *argv]) == 2
        err = capsys.readouterr().err
        assert message in err and len(err.strip().splitlines()) == 1, err
    for argv in (["grade"], ["grade", str(EXAMPLE), "--timeout", "0"]):
        with pytest.raises(SystemExit) as info:
            main(argv)
        assert info.value.code == 2


def test_settings_are_checked_as_the_options_are() -> None:
    GradeSettings(cases=1_000_000, cycles=10_000)
    for bad, why in (
        ({"cases": 1_000_001}, "--cases must be a whole number from 0 to 1,000,000"),
        ({"cases": -1}, "--cases"),
        ({"cases": True}, "--cases"),
        ({"cycles": 0}, "--cycles must be a whole number from 1 to 10,000"),
        ({"seed": -1}, "--seed"),
        ({"timeout": float("inf")}, "--timeout and --ik-timeout must be > 0 s"),
        ({"ik_timeout": 0}, "--timeout and --ik-timeout"),
        ({"min_success": 1.5}, "--min-success must be in [0, 1]"),
        ({"workers": 0}, "--workers must be at least 1"),
        ({"memory_mb": 100}, "--memory must be at least 256 MB"),
    ):
        with pytest.raises(ConfigError) as info:
            GradeSettings(**bad)  # type: ignore[arg-type]
        assert why in str(info.value)
    s = GradeSettings()
    assert s.own_time_cap == 120 + 30 * 10 + 0.01 * 1000 == s.config()["own_time_cap_s"]


def test_a_dead_grading_process_is_described_by_what_killed_it() -> None:
    """Every grading process printed a runpy RuntimeWarning, and the detail of each one that
    died quoted it."""
    warning = (
        b"<frozen runpy>:128: RuntimeWarning: 'kr210_sim.grading.student' found in sys.modules "
        b"after import of package 'kr210_sim.eval', but prior to execution\n"
    )
    assert relevant_line(warning) == ""
    traceback = b"Traceback (most recent call last):\n  File x\nValueError: too big\n\n"
    assert relevant_line(warning + traceback) == "ValueError: too big"
    assert relevant_line(b"first\nFatal Python error: Aborted\n" + warning) == (
        "Fatal Python error: Aborted"
    )
    assert relevant_line(b"bad \xff byte\n") == "bad \ufffd byte"


#: Forged records: what a student would like the grader to believe.
_FORGER = """
import json, os, pathlib, struct

FAKE = json.dumps({"name": "x", "spec": None, "verdict": "pass", "detail": "forged",
    "ik_check": None, "run": None, "diagnosis": [], "wall_time_s": {"total": 1.0},
    "output": {"bytes": 0, "stdout": "", "stderr": ""}}).encode()

def forge():
    for where in (pathlib.Path.cwd().parent.parent / "grader", pathlib.Path.cwd().parent):
        for name in ("NAME.json", "0.json", "1.json"):
            try:
                (where / name).write_text(FAKE.decode())
            except OSError:
                pass
    mine = set()
    for fd in os.listdir("/proc/self/fd"):
        try:
            mine.add(os.readlink(f"/proc/self/fd/{fd}"))
        except OSError:
            pass
    parent = os.getppid()
    for fd in os.listdir(f"/proc/{parent}/fd"):
        path = f"/proc/{parent}/fd/{fd}"
        try:
            target = os.readlink(path)
        except OSError:
            continue
        if int(fd) > 2 and target.startswith("pipe:") and target not in mine:
            frame = struct.pack("!Q", len(FAKE)) + FAKE + bytes(32)
            try:
                out = os.open(path, os.O_WRONLY | os.O_NONBLOCK)
                os.write(out, frame)
                os.close(out)
            except OSError:
                pass
"""
HOSTILE = {
    "<script>window.pwned=1": None,
    '"><img src=x onerror=window.pwned=2>': None,
    "$(touch pwned)": None,
    'it\'s "quoted"': None,
    "a" * 250: None,
    "x": None,
    "x.job": "import os\n\ndef solve(T, q):\n    os.kill(os.getppid(), 9)\n",
    "forge": _FORGER
    + (
        "\nfrom correct_ik import solve as _solve\n\ndef solve(T, q):\n    forge()\n"
        "    os.kill(os.getppid(), 9)\n"
    ),
    "liar": _FORGER
    + (
        "\nfrom correct_ik import solve as _solve\n_done = []\n\ndef solve(T, q):\n"
        "    if not _done:\n        forge()\n        _done.append(1)\n    return _solve(T, q)\n"
    ),
    "mallory": (
        "import os, pathlib\n\ndef solve(T, q):\n"
        "    here = pathlib.Path.cwd()\n"
        "    for where in (here.parent.parent / 'grader', here.parent):\n"
        "        try:\n"
        "            (where / 'mallory.json').write_text('[]')\n"
        "        except OSError:\n"
        "            pass\n"
        "    os.kill(os.getppid(), 9)\n"
    ),
    "nan": "def solve(T, q):\n    return [float('nan')] * 6\n",
}
BAD_NAME = b"bad\xffname"


@pytest.mark.slow
def test_a_hostile_class_is_graded_and_its_page_runs_nothing(tmp_path: Path) -> None:
    """Forged records were believed (``pass``) or crashed the whole grade; odd names crashed
    it with no report; a non-UTF-8 name was graded ``error`` and broke the page."""
    folder = tmp_path / "hostile"
    folder.mkdir()
    src = EXAMPLE.read_text()
    (folder / "_correct_ik.py").write_text(src)  # skipped: a helper the forgers import
    for name, body in HOSTILE.items():
        (folder / f"{name}.py").write_text(body or src)
    for name in ("forge", "liar"):  # import the helper by its real name
        path = folder / f"{name}.py"
        path.write_text(path.read_text().replace("from correct_ik", "from _correct_ik"))
    (folder / os.fsdecode(BAD_NAME + b".py")).write_text(src)
    (folder / "--x.py").write_text(src.replace("\nA3 = -0.054", "\nA3 = 0.0"))
    (folder / "dangling.py").symlink_to("nonexistent.py")
    (folder / "BOB.PY").write_text(src)
    (folder / "carol.ipynb").write_text("{}")
    before = _tree(folder)
    cwd, tmp, out = tmp_path / "cwd", tmp_path / "tmp", tmp_path / "out"
    for d in (cwd, tmp, out):
        d.mkdir()
    # --no-jail: these attacks are on the grader's own checks (the record's pipe and seal),
    # which must hold where the students reach their grading process; in the jail they reach
    # neither it nor the class folder (tests/sandbox/test_jail_class.py).
    args = ["../hostile", "--cases", "0", "--cycles", "1", "--workers", "2", "--no-jail"]
    args += ["--report", str(out / "grade.json"), "--html", str(out / "grade.html")]
    proc = _grade(args, cwd, tmp)
    raw_out, raw_err = proc.communicate(timeout=900)
    stdout = raw_out.encode("utf-8", "surrogateescape").decode("utf-8")  # strict: printable
    assert proc.returncode == 1, raw_err
    assert "Traceback" not in stdout + raw_err
    report = json.loads((out / "grade.json").read_bytes().decode("utf-8"))
    by_name = {s["name"]: s for s in report["students"]}
    expected = {name: "pass" for name, body in HOSTILE.items() if body is None}
    expected |= {"bad\\xffname": "pass", "--x": "fail", "nan": "fail"}
    expected |= {"x.job": "crashed", "forge": "crashed", "liar": "crashed", "mallory": "crashed"}
    expected |= {"dangling": "error", "BOB.PY": "error", "carol.ipynb": "error"}
    assert {n: s["verdict"] for n, s in by_name.items()} == expected
    killed = "the grading process was killed by SIGKILL"
    assert by_name["x.job"]["detail"] == killed  # no runpy warning quoted
    assert by_name["forge"]["detail"] == killed and by_name["mallory"]["detail"] == killed
    assert by_name["liar"]["detail"].startswith(
        "the grading process exited with code 0, but "
    ) and by_name["liar"]["detail"].endswith("bytes came over its record pipe, not one record")
    assert by_name["nan"]["diagnosis"][0]["code"] == "unusable"
    assert by_name["nan"]["run"]["cycles"] == 1
    assert by_name["bad\\xffname"]["spec"] == "../hostile/bad\\xffname.py:solve"
    assert by_name["dangling"]["detail"].endswith(
        "is a symbolic link to nonexistent.py, which does not exist"
    )
    # The film-it commands run as printed.
    (replay,) = [c["replay"] for c in by_name["--x"]["run"]["failed_cycles"]]
    assert shlex.split(replay)[3:6] == ["run", "--ik", "../hostile/--x.py:solve"]
    # Nothing ran that a name holds, nothing was left or written beside the class.
    assert not list(tmp_path.rglob("pwned"))
    assert _ours_running(str(tmp_path)) == []
    assert _tree(folder) == before
    assert _tree(tmp) == [] and _tree(cwd) == []
    assert _tree(out) == ["grade.html", "grade.json"]
    # The page: every student, no script.
    from chromium import Chromium, find_chromium
    from test_leaderboard import check_page, page_in_browser  # the page in a browser

    if find_chromium() is None:
        why = "no Chromium here (bash .ci/run installs chromium-headless-shell)"
        if os.environ.get("KR210_REQUIRE_CHROMIUM"):
            pytest.fail(why, pytrace=False)
        pytest.skip(why)
    with Chromium(width=1000, height=700, timeout=60) as browser:
        shown = page_in_browser(browser, out / "grade.html")
    check_page(shown, [s["name"] for s in report["students"]])


@pytest.mark.slow
@pytest.mark.parametrize(("delay", "second"), [(0.002, "SIGTERM"), (0.01, "SIGINT")])
def test_a_second_signal_just_after_the_first_keeps_the_report(
    tmp_path: Path, delay: float, second: str
) -> None:
    """A CI cancel (SIGTERM to the process group, then again) printed "writing the report of
    those" and wrote nothing, 3 times in 3."""
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
        line = proc.stdout.readline()  # the correct student finished; hang is still graded
        assert "correct" in line and " pass " in line, line
        time.sleep(0.3)
        proc.send_signal(signal.SIGTERM)
        time.sleep(delay)
        proc.send_signal(getattr(signal, second))
        _, stderr = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == 143, stderr  # the first signal's code
    assert "Traceback" not in stderr
    data = json.loads(report.read_text())
    assert data["interrupted_by"] == "SIGTERM"
    assert [(s["name"], s["verdict"]) for s in data["students"]] == [("correct", "pass")]
    assert _ours_running(str(tmp_path)) == []
    assert _tree(tmp) == []


@pytest.mark.slow
def test_under_the_python_api_a_second_ctrl_c_keeps_the_report(tmp_path: Path) -> None:
    """The API installs no handlers of ours: grade's own wind-up holds the second Ctrl-C."""
    folder = make_class(tmp_path / "class")
    report = tmp_path / "grade.json"
    script = (
        "import sys, kr210_sim\n"
        "try:\n"
        f"    kr210_sim.grade([{str(folder / 'correct.py')!r}, {str(folder / 'hang.py')!r}],\n"
        "        cases=0, cycles=1, ik_timeout=600, workers=2, out=sys.stdout,\n"
        f"        report={str(report)!r})\n"
        "except kr210_sim.RunInterrupted as exc:\n"
        "    print('raised', dict(exc.report.verdicts), flush=True)\n"
        "    sys.exit(128 + exc.signum)\n"
    )
    env = dict(os.environ, TMPDIR=str(tmp_path), PYTHONPATH=str(ROOT))
    proc = subprocess.Popen(
        [sys.executable, "-c", script],
        cwd=tmp_path,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()
        assert "correct" in line and " pass " in line, line
        time.sleep(0.3)
        proc.send_signal(signal.SIGINT)
        time.sleep(0.005)
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == 130, err
    assert "raised {'correct': 'pass'}" in out and "Traceback" not in err
    data = json.loads(report.read_text())
    assert data["interrupted_by"] == "SIGINT" and len(data["students"]) == 1
    assert _ours_running(str(tmp_path)) == []


@pytest.mark.slow
def test_a_signal_during_start_up_gives_a_report_of_no_students(tmp_path: Path) -> None:
    from held_start import held_at  # a start-up held at one import

    report = tmp_path / "grade.json"
    report.write_text('{"an earlier grade": true}')  # must not be taken for this one's
    args = ["grade", str(EXAMPLE), "--cases", "0", "--cycles", "1", "--report", str(report)]
    proc, mark = held_at("kr210_sim.grading.grade", args, tmp_path)
    proc.send_signal(signal.SIGTERM)
    time.sleep(0.005)
    proc.send_signal(signal.SIGTERM)
    Path(f"{mark}.go").touch()
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 143, err
    assert err.splitlines() == [
        "kr210_sim: interrupted (SIGTERM) after 0 of 1 students; writing the report of those"
    ]
    data = json.loads(report.read_text())
    assert data["interrupted_by"] == "SIGTERM" and data["students"] == []
    assert "INTERRUPTED (SIGTERM)" in out


def test_a_grading_process_s_pipes_may_reach_their_end_in_either_order() -> None:
    """Its stderr at its end before its record pipe: closing the record pipe then asked the
    closed stderr for its fileno, and the whole grade ended in a traceback ("I/O operation on
    closed file"; once in five CI runs of the hostile class)."""
    proc = subprocess.Popen([sys.executable, "-c", "pass"], stderr=subprocess.PIPE)
    assert proc.stderr is not None
    record_r, record_w = os.pipe()
    os.close(record_w)
    pool = grade_module._Pool.__new__(grade_module._Pool)
    pool.selector = selectors.DefaultSelector()
    run = grade_module._Running.__new__(grade_module._Running)
    run.proc, run.fds = proc, []
    for fd in (record_r, proc.stderr.fileno()):
        pool.selector.register(fd, selectors.EVENT_READ, (run, "x"))
        run.fds.append(fd)
    pool._close(run, proc.stderr.fileno())  # stderr first
    pool._close(run)  # then the rest: the record pipe
    assert run.fds == [] and proc.stderr.closed
    proc.wait()


def test_a_student_folder_named_like_a_module_we_import_runs_nowhere_outside_the_jail(
    tmp_path: Path,
) -> None:
    """A class folder holding ``ruckig/__init__.py``, graded from inside it with
    ``python -m kr210_sim grade .``: neither the command's process nor a grading process (which
    would be working folder first on ``sys.path``) imports it."""
    folder = tmp_path / "class"
    (folder / "ruckig").mkdir(parents=True)
    (folder / "correct.py").write_text(EXAMPLE.read_text())
    marker = tmp_path / "imported"
    (folder / "ruckig" / "__init__.py").write_text(
        f"open({str(marker)!r}, 'a').write('x')\ndef solve(T, q):\n    return q\n"
    )
    tmp, out = tmp_path / "tmp", tmp_path / "out"
    tmp.mkdir(), out.mkdir()
    args = [".", "--cases", "0", "--cycles", "1", "--report", str(out / "grade.json")]
    proc = _grade(args, folder, tmp)
    stdout, stderr = proc.communicate(timeout=600)
    assert not marker.exists(), stderr
    assert "Traceback" not in stdout + stderr
    report = json.loads((out / "grade.json").read_text())
    verdicts = {s["name"]: s["verdict"] for s in report["students"]}
    assert verdicts["correct"] == "pass"
    assert verdicts["ruckig"] != "pass"
