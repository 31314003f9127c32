"""What a jail shows and refuses beyond the walls (REDTEAM-4 findings 7, 8, 10, 11 and 12): the
grader's own solver, a writable ``/dev``, the grader's environment in ``/proc/1``, the targets of a
student's links, a single file's class folder, and hard links to files the student could not read.

Each test starts a real bubblewrap jail through :class:`IkSandbox` with user code written here
that tries something and prints what came of it as one JSON line.
"""

from __future__ import annotations

import json
import os
import textwrap
from pathlib import Path

import numpy as np
import pytest
import ros_class

from kr210_sim.errors import IkSpecError
from kr210_sim.grading.finding import grader_code
from kr210_sim.robot import kinematics
from kr210_sim.sandbox import harness
from kr210_sim.sandbox.ik_guard import assess
from kr210_sim.sandbox.ik_sandbox import IkSandbox, Limits
from kr210_sim.sandbox.jail import SHM_MB, Jail
from kr210_sim.sandbox.jail_files import user_files
from kr210_sim.sandbox.user_ik import spec_files
from kr210_sim.util import paths

Q = np.array([0.3, 0.2, -0.3, 0.5, 0.6, -0.4])
HEAD = "import json, os, sys\nfound = {}\n"
ATTEMPT = """
def attempt(name, fn):
    try:
        found[name] = ["got", str(fn())[:200]]
    except Exception as exc:
        found[name] = ["stopped", type(exc).__name__]
"""
TAIL = """
print("FOUND " + json.dumps(found), flush=True)

def solve(T, q):
    return q
"""


def _write(path: Path, body: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(HEAD + ATTEMPT + textwrap.dedent(body) + TAIL)
    return path


def _found(box: IkSandbox) -> dict[str, object]:
    for line in box.stdout.text().splitlines():
        if line.startswith("FOUND "):
            found: dict[str, object] = json.loads(line[6:])
            return found
    raise AssertionError(f"no FOUND line in {box.stdout.text()!r} / {box.stderr.text()!r}")


def _run(spec: str, tmp_path: Path, root: Path | None = None) -> tuple[IkSandbox, Jail]:
    jail = Jail()
    box = IkSandbox(spec, scratch=tmp_path / "scratch", capture=True, confinement=jail, root=root)
    with box:
        np.testing.assert_allclose(box(kinematics.forward(Q), Q), Q)
    return box, jail


def test_the_graders_solver_planner_and_cells_are_not_in_the_jail(
    tmp_path: Path, jail_ok: None
) -> None:
    """Finding 12: the package's own IK is neither importable nor readable; the attempt is
    kept and named, even when the student's code catches it and answers by itself."""
    package = paths.PACKAGE_DIR.resolve()
    user = _write(
        tmp_path / "class" / "sneak.py",
        f"""
        def grab(name):
            __import__(name)
            return "imported"
        for name in ("kr210_sim.robot.kinematics", "kr210_sim.robot.ik_scalar",
                     "kr210_sim.robot._ik_native", "kr210_sim.plan", "kr210_sim.cell"):
            attempt(name, lambda: grab(name))
        attempt("read_kinematics", lambda: open({str(package / "robot" / "kinematics.py")!r}))
        attempt("robot_listing", lambda: sorted(os.listdir({str(package / "robot")!r})))
        attempt("scenes", lambda: os.listdir({str(paths.ROOT / "scenes")!r}))
        attempt("assets", lambda: os.listdir({str(paths.ROOT / "assets")!r}))
        sys.meta_path[:] = [f for f in sys.meta_path if type(f).__name__ != "Guard"]
        attempt("unguarded", lambda: grab("kr210_sim.robot.description"))
        """,
    )
    box, _ = _run(f"{user}:solve", tmp_path, root=user)
    got = _found(box)
    for name in ("kr210_sim.robot.kinematics", "kr210_sim.robot.ik_scalar", "kr210_sim.plan"):
        assert got[name] == ["stopped", "ModuleNotFoundError"], name
    assert got["kr210_sim.robot._ik_native"] == ["stopped", "ModuleNotFoundError"]
    assert got["read_kinematics"] == ["stopped", "FileNotFoundError"]
    assert got["robot_listing"] == ["got", "['quaternions.py']"]
    assert got["scenes"][0] == got["assets"][0] == "stopped"  # type: ignore[index]
    assert got["unguarded"] == ["stopped", "ModuleNotFoundError"]  # no file to import either
    assert box.blocked[:3] == [
        "kr210_sim.robot.kinematics",
        "kr210_sim.robot.ik_scalar",
        "kr210_sim.robot._ik_native",
    ]
    finding = grader_code(box.blocked)
    assert finding is not None and finding.code == "grader_code"
    assert finding.text.startswith("imported the grader's own solver, planner and cells (")


def test_a_top_level_import_of_the_solver_is_an_error_that_says_so(
    tmp_path: Path, jail_ok: None
) -> None:
    user = tmp_path / "lazy.py"
    user.write_text("from kr210_sim.robot.kinematics import nearest as solve\n")
    box = IkSandbox(f"{user}:solve", capture=True, confinement=Jail(), root=user)
    with pytest.raises(IkSpecError, match="the grader's own code is not in the jail"):
        box.start()
    box.close()
    assert box.blocked == ["kr210_sim.robot.kinematics"]


def test_the_harness_serves_a_ros_form_server(tmp_path: Path, jail_ok: None) -> None:
    """The exercise's shims and the wire are all a ROS-form server needs in the jail."""
    repo = ros_class.write_class(tmp_path / "class", ("alice",)) / "alice"
    kin = kinematics.committed()
    poses = [kinematics.forward(Q), kinematics.forward(Q * 0.5)]
    with IkSandbox(
        str(repo), Limits(call_timeout=20.0), capture=True, confinement=Jail(), root=repo
    ) as box:
        answers = box.batch(poses)
    assert all(assess(kin, T, Q, a).passed for T, a in zip(poses, answers, strict=True))
    assert box.blocked == []


def test_a_spec_of_the_package_itself_is_served_whole(tmp_path: Path, jail_ok: None) -> None:
    """``--ik kr210_sim.robot.kinematics:nearest`` (the instructor's own choice) still runs."""
    with IkSandbox("kr210_sim.robot.kinematics:nearest", confinement=Jail()) as box:
        np.testing.assert_allclose(box(kinematics.forward(Q), Q), Q, atol=1e-9)
    assert box.blocked == []


def test_the_harness_names_only_files_that_exist() -> None:
    package = paths.PACKAGE_DIR.resolve()
    assert len(harness.files(package)) == len(harness.MODULES) + len(harness.FOLDERS)
    assert harness.allowed("kr210_sim.exercise.shims") and harness.allowed("kr210_sim.robot")
    assert not harness.allowed("kr210_sim.robot.kinematics")
    assert not harness.allowed("kr210_sim.sandbox.ik_guard")


def test_dev_is_read_only_and_shm_bounded(tmp_path: Path, jail_ok: None) -> None:
    """Finding 7: ``/dev`` was a writable tmpfs at half of RAM."""
    user = _write(
        tmp_path / "dev.py",
        f"""
        def fill(path, mb):
            with open(path, "wb") as f:
                for _ in range(mb):
                    f.write(b"x" * (1 << 20))
            return mb
        attempt("dev_file", lambda: fill("/dev/hold", 1))
        attempt("dev_dir", lambda: os.mkdir("/dev/d"))
        attempt("shm_within", lambda: fill("/dev/shm/a", {SHM_MB // 2}))
        attempt("shm_over", lambda: fill("/dev/shm/b", {SHM_MB}))
        attempt("null", lambda: open("/dev/null", "w").write("x"))
        attempt("urandom", lambda: len(open("/dev/urandom", "rb").read(8)))
        """,
    )
    box, _ = _run(f"{user}:solve", tmp_path, root=user)
    got = _found(box)
    assert got["dev_file"] == got["dev_dir"] == ["stopped", "OSError"]
    assert got["shm_within"] == ["got", str(SHM_MB // 2)]
    assert got["shm_over"] == ["stopped", "OSError"]
    assert got["null"] == ["got", "1"] and got["urandom"] == ["got", "8"]


def test_proc_1_shows_nothing_of_the_grader(
    tmp_path: Path, jail_ok: None, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Finding 11: bubblewrap's init (pid 1) showed the grader's PATH and its command line."""
    monkeypatch.setenv("PATH", "/grader-only/bin:" + os.environ["PATH"])
    user = _write(
        tmp_path / "class" / "peek.py",
        """
        found["environ"] = open("/proc/1/environ", "rb").read().decode(errors="replace")
        found["cmdline"] = open("/proc/1/cmdline", "rb").read().decode(errors="replace")
        found["path"] = os.environ["PATH"]
        """,
    )
    box, _ = _run(f"{user}:solve", tmp_path, root=user)
    got = _found(box)
    assert "grader-only" not in str(got["environ"]) and "PATH=" not in str(got["environ"])
    cmdline = str(got["cmdline"])
    for shown in ("--setenv", "--ro-bind", str(tmp_path / "scratch"), "grader-only"):
        assert shown not in cmdline, shown
    assert "grader-only" not in str(got["path"])


def test_ik_binds_neither_a_single_files_class_folder_nor_what_links_lead_to(
    tmp_path: Path, jail_ok: None
) -> None:
    """Finding 8: ``--ik class/alice.py`` showed the whole class folder, and a repository's
    ``kuka_arm/src -> ~instructor`` the instructor's files."""
    secret = tmp_path / "instructor"
    secret.mkdir()
    (secret / "key.py").write_text("KEY = 'answer-key'\n")
    klass = tmp_path / "class"
    klass.mkdir()
    (klass / "bob.py").write_text("SECRET = 'bob'\n")
    user = _write(
        klass / "alice.py",
        f"""
        attempt("sibling", lambda: open({str(klass / "bob.py")!r}).read())
        attempt("class", lambda: sorted(os.listdir({str(klass)!r})))
        """,
    )
    box, _ = _run(f"{user}:solve", tmp_path)  # no root: as ik-check --ik and run --ik
    got = _found(box)
    assert got["sibling"] == ["stopped", "FileNotFoundError"]
    assert got["class"] == ["got", "['alice.py']"]
    # A ROS-form repository whose src links out: the link is named, never followed.
    repo = ros_class.write_class(tmp_path / "ros", ("alice",)) / "alice"
    (repo / "kuka_arm" / "src").symlink_to(secret)
    readable = spec_files(str(repo)).readable
    assert repo / "kuka_arm" / "src" in readable
    shown = user_files(readable)
    assert shown.links == 1 and not any(f.is_relative_to(secret) for f in shown.files)
    assert shown.findings() == [
        "1 of the student's files not shown in the jail (named by a link that was not followed)"
    ]


def test_a_hard_link_to_a_file_the_student_could_not_read_is_not_shown(
    tmp_path: Path, jail_ok: None
) -> None:
    """Finding 10: a hard link in a student's folder to an instructor's 0600 file."""
    key = tmp_path / "key.txt"
    key.write_text("answer-key")
    key.chmod(0o600)
    folder = tmp_path / "class" / "mallory"
    folder.mkdir(parents=True)
    os.link(key, folder / "stolen.txt")
    (folder / "mine.txt").write_text("mine")
    user = _write(
        folder / "ik.py",
        f"""
        attempt("stolen", lambda: open({str(folder / "stolen.txt")!r}).read())
        attempt("mine", lambda: open({str(folder / "mine.txt")!r}).read())
        """,
    )
    box, jail = _run(f"{user}:solve", tmp_path, root=folder)
    got = _found(box)
    assert got["stolen"] == ["stopped", "FileNotFoundError"]
    assert got["mine"] == ["got", "mine"]
    assert (
        "1 of the student's files not shown in the jail (hard-linked to a file the student "
        "could not read)"
    ) in jail.findings()


def test_a_jail_weighs_next_to_nothing_between_its_calls(tmp_path: Path, jail_ok: None) -> None:
    """Finding 13: threads on every core between a student's calls cost a neighbour nothing;
    while asked, it weighs as any process."""
    import threading
    import time

    user = tmp_path / "slow.py"
    user.write_text("import time\ndef solve(T, q):\n    time.sleep(1.0)\n    return q\n")
    jail = Jail()
    if not jail.limiter.cpu:
        pytest.skip("no cpu control group can be made here")
    box = IkSandbox(f"{user}:solve", Limits(call_timeout=10.0), confinement=jail, root=user)
    with box:
        box.start()
        assert box._proc is not None
        group = jail._started[box._proc.pid].group
        assert group is not None and group.cpu is not None
        v2 = (group.cpu / "cpu.weight").exists()
        weight = group.cpu / ("cpu.weight" if v2 else "cpu.shares")
        assert weight.read_text().split() == ["1" if v2 else "2"]  # ready, not asked
        call = threading.Thread(target=box, args=(kinematics.forward(Q), Q))
        call.start()
        time.sleep(0.5)
        during = weight.read_text().split()
        call.join()
        assert during == ["100" if v2 else "1024"]
        assert weight.read_text().split() == ["1" if v2 else "2"]


def test_the_harness_imports_only_the_harness() -> None:
    """Every kr210_sim import written in the harness's files (the exercise's shims included)
    names a module the jail holds: an import added elsewhere would fail in every jail."""
    import ast

    package = paths.PACKAGE_DIR.resolve()
    files = [
        f for p in harness.files(package) for f in ([p] if p.is_file() else sorted(p.rglob("*.py")))
    ]
    outside = []
    for f in files:
        for node in ast.walk(ast.parse(f.read_text())):
            names: list[str] = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                names = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
            for name in names:
                module = name if not name.endswith(".*") else name[:-2]
                if module.startswith("kr210_sim") and not harness.allowed(module):
                    if module.rpartition(".")[0] and harness.allowed(module.rpartition(".")[0]):
                        parent = module.rpartition(".")[0]
                        if parent in {harness.module_name(m) for m in harness.MODULES}:
                            continue  # a name imported from a harness module
                    outside.append(f"{f.relative_to(package)}: {module}")
    assert outside == []


def test_an_installed_package_is_hidden_under_the_harness(
    tmp_path: Path, jail_ok: None, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Installed (not editable), kr210_sim lies in site-packages, which the jail binds whole:
    an empty folder over the package's path hides it, and the harness is bound into that."""
    from kr210_sim.sandbox import jail as jail_module

    package = paths.PACKAGE_DIR.resolve()
    roots = jail_module.python_roots
    monkeypatch.setattr(jail_module, "python_roots", lambda: [*roots(), package.parent])
    user = _write(
        tmp_path / "peek.py",
        f"""
        attempt("kinematics", lambda: open({str(package / "robot" / "kinematics.py")!r}))
        attempt("robot", lambda: sorted(os.listdir({str(package / "robot")!r})))
        attempt("beside", lambda: sorted(os.listdir({str(package.parent)!r}))[:1] != [])
        attempt("write", lambda: open({str(package / "x.py")!r}, "w"))
        """,
    )
    box, _ = _run(f"{user}:solve", tmp_path, root=user)
    got = _found(box)
    assert got["beside"] == ["got", "True"]  # the folder around it is bound whole
    assert got["kinematics"] == ["stopped", "FileNotFoundError"]
    assert got["robot"] == ["got", "['quaternions.py']"]
    assert got["write"][0] == "stopped"  # type: ignore[index]
