"""A hostile class of our own, graded in one call in the jail (sandbox/jail.py, grading/grade.py).

Each member attacks at import (some again at its first call) and then answers with the package's
own IK, so its verdict is ``pass`` unless the attack got through: a sibling's submission and a
file beside the class read; a listener on the host's loopback (started here) reached; a fork
bomb; six forks of 300 MB each (within ``--memory`` each, not together); a ``setsid`` daemon
that tries to write beside the report later; writes to a sibling, the class folder, the
installed package and the report folder; the grader and its own parent killed; threads on every
core; 30 MB of output; and a frame on its answer pipe that claims 2 GB and never comes. Two
members of the ordinary test class sit beside them. Checked from outside: nothing was read,
reached, written or killed, nothing is left running, each verdict says what the jail stopped
where the kernel counts it, and the ordinary members keep their verdicts.
"""

from __future__ import annotations

import io
import json
import os
import socket
import textwrap
import time
from pathlib import Path

import pytest
from memory_hog import hog

import kr210_sim
from kr210_sim.sandbox.jail import Jail
from kr210_sim.util import paths

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "ik_dh.py"
SIBLING_SECRET = "sibling-secret-7f3a"
KEY_SECRET = "answer-key-91c2"
#: What every member ends with: the worked example's IK (the grader's own is not in the jail).
ANSWER = "\n" + EXAMPLE.read_text().replace("from __future__ import annotations\n", "")


def _members(klass: Path, out: Path, port: int, marker: str) -> dict[str, str]:
    bob = klass / "bob" / "ik.py"
    return {
        "reader": f"""
            for path in ({str(bob)!r}, {str(klass.parent / "answer_key.txt")!r}):
                try:
                    print("READ", open(path).read())
                except OSError as exc:
                    print("stopped", type(exc).__name__)
            """,
        "net": f"""
            import socket
            for host in ("127.0.0.1", "::1"):
                try:
                    socket.create_connection((host, {port}), timeout=2).close()
                    print("CONNECTED", host)
                except OSError as exc:
                    print("stopped", type(exc).__name__)
            """,
        "bomb": """
            import os, time
            kids = 0
            try:
                while kids < 2000:
                    if os.fork() == 0:
                        time.sleep(600)
                        os._exit(0)
                    kids += 1
            except OSError as exc:
                print("stopped after", kids, type(exc).__name__)
            """,
        "daemon": f"""
            import os, sys
            if os.fork() == 0:
                os.setsid()
                if os.fork() == 0:
                    code = (
                        "import time\\ntime.sleep(3)\\n"
                        "for p in ({str(out / "daemon.txt")!r}, {str(klass / "daemon.txt")!r}):\\n"
                        "    try:\\n        open(p, 'w').write('x')\\n    except OSError:\\n"
                        "        pass\\ntime.sleep(600)\\n"
                    )
                    os.execv(sys.executable, [sys.executable, "-c", code, {marker!r}])
                os._exit(0)
            """,
        "writer": f"""
            targets = ({str(bob)!r}, {str(klass / "new.py")!r},
                       {str(paths.PACKAGE_DIR / "pwned_by_writer.py")!r},
                       {str(out / "pwned.txt")!r}, {str(out / "grade.json")!r})
            for path in targets:
                try:
                    open(path, "a").write("pwned")
                    print("WROTE", path)
                except OSError as exc:
                    print("stopped", type(exc).__name__)
            """,
        "killer": f"""
            import os, signal
            def kill_all():
                for name, pid in (("grader", {os.getpid()}), ("parent", os.getppid())):
                    try:
                        os.kill(pid, signal.SIGKILL)
                        print("sent", name)
                    except OSError as exc:
                        print("stopped", name, type(exc).__name__)
                for entry in os.listdir("/proc"):  # every grading process it can find
                    try:
                        if entry.isdigit() and b"kr210_sim.grading.student" in open(
                            f"/proc/{{entry}}/cmdline", "rb"
                        ).read():
                            os.kill(int(entry), signal.SIGKILL)
                            print("KILLED a grading process", entry)
                    except OSError:
                        pass
            kill_all()
            """,
        "hog": hog(6, 300, 4) + "print('killed', killed)\n",
        "threads": """
            import hashlib, os, threading
            def burn():
                block = b"x" * (1 << 20)
                while True:
                    hashlib.sha256(block).digest()  # the GIL is let go while it hashes
            for _ in range(2 * (os.cpu_count() or 1)):
                threading.Thread(target=burn, daemon=True).start()
            """,
        "sneak": """
            try:  # the grader's own solver, with a fallback: refused, and named in the verdict
                from kr210_sim.robot.kinematics import nearest as solve
            except ImportError:
                pass
            """,
        "chatty": """
            import sys
            line = "y" * 1023 + "\\n"
            for _ in range(30 * 1024):
                sys.stdout.write(line)
            """,
        "pipe": """
            import os, sys, time, struct
            _first = []
            def _stall():
                if not _first:
                    _first.append(1)
                    os.write(int(sys.argv[3]), struct.pack("!I", 2 << 30) + b"{")
                    time.sleep(600)
            """,
    }


@pytest.mark.slow
def test_a_hostile_class_is_graded_in_one_call_and_every_attack_is_stopped(
    tmp_path: Path, jail_ok: None
) -> None:
    klass, out = tmp_path / "class", tmp_path / "out"
    out.mkdir()
    (klass / "bob").mkdir(parents=True)
    (klass / "bob" / "ik.py").write_text(f"# {SIBLING_SECRET}\n" + EXAMPLE.read_text())
    (tmp_path / "answer_key.txt").write_text(KEY_SECRET)
    src = EXAMPLE.read_text()
    (klass / "no_offset.py").write_text(src.replace("\nA3 = -0.054", "\nA3 = 0.0"))
    # Entries that link out of the class folder (an unpacked archive's): not graded, or its
    # jail would show it what they lead to.
    (tmp_path / "home").mkdir()
    (tmp_path / "home" / "ik.py").write_text(f"# {KEY_SECRET}\n" + src)
    (klass / "linker").symlink_to(tmp_path / "home")
    (klass / "linked.py").symlink_to(tmp_path / "home" / "ik.py")
    marker = f"kr210-hostile-daemon-{os.getpid()}-{time.monotonic_ns()}"
    pwned = paths.PACKAGE_DIR / "pwned_by_writer.py"
    with socket.socket() as listener:
        listener.bind(("127.0.0.1", 0))
        listener.listen(8)
        listener.setblocking(False)
        members = _members(klass, out, listener.getsockname()[1], marker)
        for name, attack in members.items():
            body = textwrap.dedent(attack) + ANSWER
            if name == "pipe":
                body += (
                    "\n_ours = solve\n\ndef solve(T, q):\n    _stall()\n    return _ours(T, q)\n"
                )
            (klass / f"{name}.py").write_text(body)
        before = sorted(str(p.relative_to(klass)) for p in klass.rglob("*"))
        try:
            result = kr210_sim.grade(
                klass,
                cases=0,
                cycles=1,
                timeout=60,
                workers=2,
                report=out / "grade.json",
                out=io.StringIO(),
            )
        finally:
            pwned.unlink(missing_ok=True)  # (only there if the jail failed)
        with pytest.raises(BlockingIOError):
            listener.accept()  # nobody reached the host's loopback
    time.sleep(4)  # past the daemon's write, had it lived
    by_name = {s["name"]: s for s in result.students}
    verdicts = {n: s["verdict"] for n, s in by_name.items()}
    assert verdicts == {
        "bob": "pass",
        "no_offset": "fail",  # the ordinary class keeps its verdicts
        **{n: "pass" for n in members if n != "pipe"},
        "pipe": "timeout",  # a frame that never comes counts against its sender
        "linker": "error",
        "linked": "error",
    }
    assert by_name["linker"]["detail"] == (
        f"{klass / 'linker'} is a symbolic link out of its class folder, to {tmp_path / 'home'}: "
        "not graded (copy the submission into the class folder)"
    )
    assert by_name["no_offset"]["diagnosis"][0]["code"] == "offset_0054"
    report = (out / "grade.json").read_text()
    assert SIBLING_SECRET not in report and KEY_SECRET not in report
    for name in ("reader", "net", "writer"):
        stdout = by_name[name]["output"]["stdout"]
        assert "READ" not in stdout and "CONNECTED" not in stdout and "WROTE" not in stdout
        assert stdout.count("stopped") == {"reader": 2, "net": 2, "writer": 5}[name]
    assert "KILLED" not in by_name["killer"]["output"]["stdout"]
    assert "stopped grader ProcessLookupError" in by_name["killer"]["output"]["stdout"]
    # Nothing left running, nothing written outside the jail.
    assert not [p for p in Path("/proc").iterdir() if p.name.isdigit() and _holds(p, marker)], (
        "the daemon outlived the grading"
    )
    assert sorted(str(p.relative_to(klass)) for p in klass.rglob("*")) == before
    assert (klass / "bob" / "ik.py").read_text().startswith(f"# {SIBLING_SECRET}\n")
    assert sorted(p.name for p in out.iterdir()) == ["grade.json"]
    assert not pwned.exists()
    # What the jail stopped, in each verdict where the kernel counted it.
    jail = Jail()
    bomb = by_name["bomb"]["detail"]
    assert "the jail stopped: " in bomb
    if jail.limiter.by:
        assert f"refused at the bound of 64 processes ({jail.limiter.by}" in bomb
        assert "still running when its IK process was ended" in bomb
    assert "1 process of its own still running" in by_name["daemon"]["detail"]
    assert "network connections and" in by_name["net"]["detail"]
    if jail.limiter.memory:  # the memory of its processes in all
        assert (
            "killed out of memory at the bound of 1,344 MB for the whole jail"
            in (by_name["hog"]["detail"])
        )
        assert by_name["hog"]["jail"]["memory"] == jail.describe()["memory"]
        assert 1000 < by_name["hog"]["jail"]["memory_peak_mb"] <= 1344
        assert by_name["bob"]["jail"]["memory_peak_mb"] < 400  # an ordinary student
    if jail.limiter.cpu:  # held to one core (how often it was held back depends on the load)
        assert by_name["threads"]["jail"]["cpu"] == jail.describe()["cpu"]
        assert jail.describe()["cpu"].startswith("1 core (cgroup v")
    chatty = by_name["chatty"]["output"]
    assert chatty["bytes"] == 30 * 1024 * 1024 and len(chatty["stdout"]) < 40_000
    assert by_name["pipe"]["detail"].startswith("no answer within 2 s")
    sneak = by_name["sneak"]
    assert "imported the grader's own solver (kr210_sim.robot.kinematics)" in sneak["detail"]
    assert sneak["diagnosis"][0]["code"] == "grader_code"
    assert all(d["code"] != "grader_code" for d in by_name["bob"]["diagnosis"])
    for name in ("bob", "no_offset", "reader", "writer", "killer", "chatty"):
        assert "the jail stopped" not in by_name[name]["detail"], name
    config = json.loads(report)["config"]
    assert config["jail"] is True and config["confinement"]["confinement"] == "bwrap"
    assert by_name["bob"]["jail"]["processes"]["limit"] == 64


def _holds(proc: Path, marker: str) -> bool:
    try:
        return marker.encode() in (proc / "cmdline").read_bytes()
    except OSError:
        return False
