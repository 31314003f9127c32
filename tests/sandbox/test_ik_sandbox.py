"""A user's IK in a process of its own (sandbox/ik_sandbox.py): answers, limits, faults, cleanup."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from kr210_sim.errors import IkSpecError
from kr210_sim.robot import kinematics
from kr210_sim.sandbox.ik_guard import assess
from kr210_sim.sandbox.ik_sandbox import (
    Captured,
    IkCrashed,
    IkSandbox,
    IkTimeout,
    Limits,
    SandboxStop,
)
from kr210_sim.sandbox.user_ik import load_ik

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "ik_dh.py"
Q = np.array([0.3, 0.2, -0.3, 0.5, 0.6, -0.4])


def _file(folder: Path, name: str, body: str) -> str:
    path = folder / f"{name}.py"
    path.write_text(textwrap.dedent(body))
    return f"{path}:solve"


def _gone(pid: int, within: float = 5.0) -> bool:
    """Whether process ``pid`` ends (or is a zombie waiting to be reaped) within ``within`` s."""
    end = time.monotonic() + within
    while time.monotonic() < end:
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(") ", 1)[1][0]
        except (OSError, IndexError):
            return True
        if state == "Z":
            return True
        time.sleep(0.05)
    return False


def test_answers_are_those_of_the_function_in_process(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    g = kinematics.committed().geometry
    here = load_ik(f"{EXAMPLE}:solve").function
    with IkSandbox(f"{EXAMPLE}:solve", scratch=tmp_path / "scratch") as box:
        for q in rng.uniform(g.lower, g.upper, size=(20, 6)):
            T = kinematics.forward(q)
            np.testing.assert_array_equal(box(T, q), np.asarray(here(T, q)))  # bit for bit
        assert box.starts == 1
    assert (tmp_path / "scratch").is_dir()  # a given scratch folder is kept


def test_raised_none_and_junk_are_judged_as_in_process(tmp_path: Path) -> None:
    spec = _file(
        tmp_path,
        "odd",
        """
        def solve(T, q):
            if q[0] > 0.5:
                raise ValueError("no  branch\\nhere")
            if q[0] > 0.0:
                return None
            if q[0] > -0.5:
                return "six angles"
            return [[1.0, 2.0], [3.0, 4.0]]
        """,
    )
    T = kinematics.forward(Q)
    with IkSandbox(spec) as box:
        problems = [
            assess(kinematics.committed(), T, Q, _raw(box, T, q0)).problem
            for q0 in (0.7, 0.3, -0.3, -0.7)
        ]
    assert problems[0] == "raised ValueError: no branch here (odd.py line 4)"  # its line, too
    assert problems[1] == "returned None (unreachable)"
    assert problems[2].startswith("returned str, not six numbers (")
    assert problems[3] == "returned shape (2, 2), not six angles"


def _raw(box: IkSandbox, T: np.ndarray, q0: float) -> object:
    q = Q.copy()
    q[0] = q0
    try:
        return box(T, q)
    except Exception as exc:
        return exc


def test_a_hanging_call_is_a_timeout_and_the_next_call_starts_afresh(tmp_path: Path) -> None:
    spec = _file(
        tmp_path,
        "sometimes",
        """
        import time
        def solve(T, q):
            if q[0] > 0:
                while True:
                    time.sleep(0.01)
            return list(q)
        """,
    )
    T = kinematics.forward(Q)
    with IkSandbox(spec, Limits(call_timeout=0.5)) as box:
        t0 = time.monotonic()
        with pytest.raises(IkTimeout, match=r"^no answer within 0\.5 s$"):
            box(T, Q)
        assert time.monotonic() - t0 < 3.0
        assert box._proc is None  # killed
        q = -Q
        np.testing.assert_array_equal(box(T, q), q)  # a fresh process answers
        assert box.starts == 2
    assert not box.scratch.exists()  # a scratch folder made by the sandbox goes with it


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ("import os\ndef solve(T, q):\n    os._exit(3)\n", "the IK process exited with code 3"),
        ("import sys\ndef solve(T, q):\n    sys.exit(4)\n", r"called sys.exit\(4\)"),
        (
            "import os, signal\ndef solve(T, q):\n    os.kill(os.getpid(), signal.SIGSEGV)\n",
            "the IK process was killed by SIGSEGV",
        ),
        (
            "def solve(T, q):\n    x = bytearray(8 << 30)\n    return x\n",
            "ran out of memory during a call \\(limit 512 MB\\)",
        ),
    ],
)
def test_a_dead_process_is_a_crash_with_what_killed_it(
    tmp_path: Path, body: str, message: str
) -> None:
    spec = _file(tmp_path, "dies", body)
    with IkSandbox(spec, Limits(memory_mb=512)) as box:
        with pytest.raises(IkCrashed, match=message):
            box(kinematics.forward(Q), Q)


def test_stop_mode_ends_with_a_verdict(tmp_path: Path) -> None:
    hang = _file(tmp_path, "hang", "def solve(T, q):\n    while True:\n        pass\n")
    with IkSandbox(hang, Limits(call_timeout=0.3), stop=True) as box:
        with pytest.raises(SandboxStop) as info:
            box(kinematics.forward(Q), Q)
    assert (info.value.verdict, info.value.detail) == ("timeout", "no answer within 0.3 s")
    # The whole student's deadline cuts a call's limit and is named as the cause.
    with IkSandbox(hang, Limits(call_timeout=30), stop=True, deadline=time.monotonic()) as box:
        with pytest.raises(SandboxStop, match="the time limit for the whole student ran out"):
            box(kinematics.forward(Q), Q)
    bad = _file(tmp_path, "bad", "def solve(T, q)\n    return q\n")
    with IkSandbox(bad, stop=True) as box:
        with pytest.raises(SandboxStop) as info:
            box.start()
    assert info.value.verdict == "error"
    assert info.value.detail.endswith("bad.py line 1: expected ':'")


def test_a_bad_spec_is_the_loaders_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    Path("mine.py").write_text("def other(T, q):\n    return q\n")
    with IkSandbox("mine.py:solve") as box:  # a relative path, resolved where we are
        with pytest.raises(IkSpecError) as info:
            box.start()
    assert (
        str(info.value)
        == "--ik 'mine.py:solve': mine.py has no function 'solve' (it defines: other)"
    )


def test_output_is_captured_bounded_and_nothing_is_written_beside_the_file(
    tmp_path: Path,
) -> None:
    folder = tmp_path / "student"
    folder.mkdir()
    spec = _file(
        folder,
        "chatty",
        """
        import sys, os
        def solve(T, q):
            print("first line")
            for i in range(20000):
                print("x" * 99)
            print("last line", file=sys.stderr)
            open("scratch_file.txt", "w").write(os.getcwd())
            return list(q)
        """,
    )
    scratch = tmp_path / "scratch"
    with IkSandbox(spec, capture=True, scratch=scratch) as box:
        box(kinematics.forward(Q), Q)
        box.close_process()
        assert box.stdout.total == len("first line\n") + 20000 * 100
        text = box.stdout.text()
    assert text.startswith("first line\n") and len(text) < 40_000
    assert "bytes left out ..." in text
    assert box.stderr.text() == "last line\n"
    assert (scratch / "scratch_file.txt").read_text() == str(scratch.resolve())
    assert sorted(p.name for p in folder.iterdir()) == ["chatty.py"]  # no __pycache__


def test_captured_keeps_head_and_tail() -> None:
    c = Captured(keep=10)
    for chunk in (b"abc", b"defgh", b"ijklmnop", b"qrs"):
        c.add(chunk)
    assert (bytes(c.head), bytes(c.tail), c.total) == (b"abcde", b"opqrs", 19)
    assert c.text() == "abcde\n[... 9 bytes left out ...]\nopqrs"


def test_processes_the_user_code_starts_are_killed_with_it(tmp_path: Path) -> None:
    spec = _file(
        tmp_path,
        "spawns",
        """
        import subprocess
        child = subprocess.Popen(["sleep", "300"])
        open("child_pid", "w").write(str(child.pid))
        def solve(T, q):
            return list(q)
        """,
    )
    scratch = tmp_path / "scratch"
    with IkSandbox(spec, scratch=scratch) as box:
        box(kinematics.forward(Q), Q)
        child = int((scratch / "child_pid").read_text())
        os.kill(child, 0)  # running
    assert _gone(child), "a process the user's code started outlived the sandbox"


def test_the_process_dies_with_its_parent(tmp_path: Path) -> None:
    hang = _file(tmp_path, "hang", "def solve(T, q):\n    while True:\n        pass\n")
    pid_file = tmp_path / "pid"
    script = textwrap.dedent(
        f"""
        import numpy as np
        from kr210_sim.sandbox.ik_sandbox import IkSandbox, Limits
        box = IkSandbox({hang!r}, Limits(call_timeout=600))
        box.start()
        open({str(pid_file)!r}, "w").write(str(box._proc.pid))
        box(np.eye(4), np.zeros(6))
        """
    )
    parent = subprocess.Popen([sys.executable, "-c", script])
    try:
        end = time.monotonic() + 60
        while not (pid_file.exists() and pid_file.read_text()) and time.monotonic() < end:
            time.sleep(0.05)
        child = int(pid_file.read_text())
        time.sleep(0.3)
        os.kill(parent.pid, signal.SIGKILL)  # no cleanup of its own can run
        parent.wait(timeout=10)
        assert _gone(child), "the user's process outlived its parent"
    finally:
        parent.kill()
        parent.wait()


# ----------------------------------------------------------------------------- --ik-timeout
HANGS_ONCE = """
import os
from ik_dh_copy import solve as _solve

def solve(T, q):
    if not os.path.exists("hung_once"):  # in the scratch folder: survives a restart unjailed
        open("hung_once", "w").close()
        while True:
            pass
    return _solve(T, q)
"""


#: HANGS_ONCE needs state that survives a restart: the scratch folder, unjailed (each start of
#: a jail is a fresh one, tests/sandbox/test_jail.py).
UNJAILED = "--no-jail"


def _hangs_once(folder: Path) -> str:
    (folder / "ik_dh_copy.py").write_text(EXAMPLE.read_text())
    return _file(folder, "hangs_once", HANGS_ONCE)


def test_load_user_ik_runs_it_apart_once_per_spec_and_limit(tmp_path: Path) -> None:
    from kr210_sim.sandbox.guarded import load_user_ik

    spec = f"{EXAMPLE}:solve"
    assert load_user_ik(spec) is load_ik(spec)  # no limit: imported here
    guarded = load_user_ik(spec, 3.0)
    assert isinstance(guarded.function, IkSandbox) and guarded.spec == spec
    assert load_user_ik(spec, 3.0) is guarded
    T = kinematics.forward(Q)
    np.testing.assert_allclose(guarded.function(T, Q), Q, atol=1e-9)
    with pytest.raises(IkSpecError, match="no such file"):
        load_user_ik(str(tmp_path / "nope.py:solve"), 1.0)


@pytest.mark.slow
def test_a_hanging_answer_ends_its_cycle_as_ik_failed_and_the_run_goes_on(
    tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    from kr210_sim.cli import main

    spec = _hangs_once(tmp_path)
    report = tmp_path / "run.json"
    t0 = time.monotonic()
    argv = ["run", "--ik", spec, "--ik-timeout", "1", UNJAILED, "--cycles", "2", "--slot", "5"]
    assert main([*argv, "--report", str(report)]) == 1  # 1 of 2 is below the 80 % bar
    assert time.monotonic() - t0 < 120
    out = capsys.readouterr().out
    assert "FAIL ik_failed" in out and "raised IkTimeout: no answer within 1 s" in out
    cycles = __import__("json").loads(report.read_text())["cycles"]
    assert [c["reason"] for c in cycles] == ["ik_failed", None]
    assert cycles[0]["detail"].startswith("standoff pose [")
    assert cycles[0]["detail"].endswith(f": {spec} raised IkTimeout: no answer within 1 s")


@pytest.mark.slow
def test_ik_check_and_evaluate_take_the_limit_too(
    tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    import json

    from kr210_sim.cli import main

    spec = _hangs_once(tmp_path)
    report = tmp_path / "ik.json"
    argv = ["ik-check", "--ik", spec, "--ik-timeout", "1", UNJAILED, "--cases", "0"]
    assert main([*argv, "--report", str(report)]) == 1
    cases = json.loads(report.read_text())["cases"]
    assert [c["error"] for c in cases if not c["passed"]] == ["IkTimeout: no answer within 1 s"]
    assert len(cases) == 68 and cases[0]["error"] is not None  # the first call hung
    again = tmp_path / "again"  # a new SPEC: a new sandbox (one per SPEC and limit), not hung yet
    again.mkdir()
    spec = _hangs_once(again)
    report = tmp_path / "ev" / "evaluate.json"
    argv = ["evaluate", "--ik", spec, "--ik-timeout", "1", UNJAILED, "--episodes", "2"]
    argv += ["--workers", "1"]
    assert main([*argv, "--report", str(report)]) == 1
    data = json.loads(report.read_text())
    assert data["summary"]["successes"] == 1
    assert [e["reason"] for e in data["failed_episodes"]] == ["ik_failed"]
    assert data["config"]["ik_timeout_s"] == 1.0
    assert "--ik-timeout 1" in data["config"]["replay"]
    capsys.readouterr()


def test_ik_timeout_needs_ik(capsys: pytest.CaptureFixture) -> None:
    from kr210_sim.cli import main

    assert main(["run", "--ik-timeout", "1", "--cycles", "1"]) == 2
    assert capsys.readouterr().err.strip() == "kr210_sim: error: --ik-timeout needs --ik SPEC"


def test_limits_are_checked() -> None:
    from kr210_sim.errors import ConfigError

    with pytest.raises(ConfigError, match="call_timeout must be > 0 s, got 0"):
        Limits(call_timeout=0)
    with pytest.raises(ConfigError, match="memory_mb must be at least 256, got 100"):
        Limits(memory_mb=100)


def test_huge_texts_and_frames_are_unusable_answers_not_crashes(tmp_path: Path) -> None:
    """An exception with a 2 MB message, a 1.2 MB string, and a frame of 3 MB written straight to
    the answer pipe are each an answer the guard can name, and the process answers on."""
    spec = _file(
        tmp_path,
        "big",
        """
        import os, struct, sys
        def solve(T, q):
            if q[0] > 0.5:
                raise ValueError("no solution: " + "x" * 2_000_000)
            if q[0] > 0.0:
                return "q=" + "0," * 600_000
            if q[0] > -0.5:
                data = b"[" + b"0," * 1_500_000 + b"0]"
                os.write(int(sys.argv[3]), struct.pack("!I", len(data)) + data)
                return None  # this one's own answer is never read: the call has had one
            return list(q)
        """,
    )
    T = kinematics.forward(Q)
    with IkSandbox(spec) as box:
        raised = _raw(box, T, 0.7)
        assert isinstance(raised, Exception) and type(raised).__name__ == "ValueError"
        assert str(raised).startswith("no solution: xxx")
        assert str(raised).endswith(" [... 1,998,013 more characters] (big.py line 5)")
        assert len(str(raised)) < 2_100
        text = assess(kinematics.committed(), T, Q, _raw(box, T, 0.3)).problem
        assert text.startswith("returned str, not six numbers (TypeError: could not convert")
        assert len(text) < 2_200
        problem = assess(kinematics.committed(), T, Q, _raw(box, T, -0.3)).problem
        assert problem == (
            "returned an answer of 3,000,003 bytes, not six numbers (TypeError: a message may "
            "hold at most 1,048,576 bytes; six angles take about 150)"
        )
        # The frame's own call's answer (None) arrives after it: dropped as an earlier call's.
        q = Q.copy()
        q[0] = -0.7
        np.testing.assert_array_equal(box(T, q), q)
        assert box.starts == 1 and box.faults == []


def test_a_module_spec_imports_where_it_does_here(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``my_ik:solve`` found on this process's path (the folder ``python -m`` is run from) is
    found by the sandboxed process too, which starts elsewhere (its scratch folder)."""
    from kr210_sim.sandbox.user_ik import SpecFiles, spec_files

    folder = tmp_path / "work"
    folder.mkdir()
    (folder / "my_ik.py").write_text(EXAMPLE.read_text())
    monkeypatch.syspath_prepend(str(folder))
    files = spec_files("my_ik:solve")
    assert files.readable == ((folder / "my_ik.py").resolve(),)
    assert files.search == (folder.resolve(),)
    assert spec_files("kr210_sim.robot.kinematics:nearest") == SpecFiles((), ())  # ours
    assert spec_files("numpy:zeros").readable == ()  # installed: nothing of the user's
    assert spec_files(f"{EXAMPLE}:solve").readable == (EXAMPLE.resolve(),)  # the file alone
    T = kinematics.forward(Q)
    with IkSandbox("my_ik:solve") as box:
        np.testing.assert_allclose(box(T, Q), Q, atol=1e-9)
        assert box.scratch != folder


def test_a_confinement_starts_and_ends_the_process(tmp_path: Path) -> None:
    """The sandbox hands its process to a Confinement as a Launch (the user's files it reads, its
    scratch folder) and has the same confinement end it."""
    from kr210_sim.sandbox.confine import Launch, Unconfined, popen

    class Wrapped(Unconfined):
        """Runs the command under /usr/bin/env, as a jail wraps it, and keeps what it saw."""

        name = "env"

        def __init__(self) -> None:
            self.launches: list[Launch] = []
            self.ended: list[int] = []

        def popen(self, launch: Launch) -> subprocess.Popen[bytes]:
            self.launches.append(launch)
            return popen(launch, ("/usr/bin/env", "KR210_WRAPPED=1", *launch.argv))

        def end(self, proc: subprocess.Popen[bytes]) -> None:
            self.ended.append(proc.pid)
            super().end(proc)

    spec = _file(
        tmp_path,
        "wrapped",
        "import os\ndef solve(T, q):\n    return list(q) if os.environ['KR210_WRAPPED'] else 0\n",
    )
    jail = Wrapped()
    box = IkSandbox(spec, confinement=jail, scratch=tmp_path / "s")
    np.testing.assert_array_equal(box(kinematics.forward(Q), Q), Q)
    (launch,) = jail.launches
    pid = box._proc.pid if box._proc else -1
    assert launch.readable == ((tmp_path / "wrapped.py").resolve(),)  # the file alone
    assert launch.scratch == (tmp_path / "s").resolve()
    assert launch.argv[3] == "kr210_sim.sandbox.ik_child"
    box.close()
    assert jail.ended == [pid] and _gone(pid)
    root = tmp_path / "only_this.py"
    root.write_text("")
    assert IkSandbox(spec, root=root).readable == (root.resolve(),)


#: A user's ``solve`` that writes a frame of its own to the grader's answer pipe before its
#: answer (it finds the pipe's descriptor in the harness's frames).
FORGER = """
import os, struct, sys

def solve(T, q):
    f = sys._getframe()
    while not isinstance(f.f_locals.get("ans"), int):
        f = f.f_back
    body = b"[" * 100000
    os.write(f.f_locals["ans"], struct.pack("!I", len(body)) + body)
    return list(q)
"""


def test_a_frame_the_users_code_writes_itself_is_a_fault_that_says_so(tmp_path: Path) -> None:
    """A frame nested past the JSON decoder's depth raised RecursionError out of the grader's
    side; any frame that is not the harness's is now the user's fault, named."""
    (tmp_path / "forger.py").write_text(FORGER)
    q = np.array([0.3, 0.2, -0.3, 0.5, 0.6, -0.4])
    with IkSandbox(f"{tmp_path / 'forger.py'}:solve", Limits(call_timeout=5.0)) as box:
        with pytest.raises(IkCrashed, match=r"^wrote 100,000 bytes to the grader's answer pipe"):
            box(kinematics.forward(q), q)
