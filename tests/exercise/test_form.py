"""Telling the original form from ours, finding the server in a repository, and its working
folder seeded with the files beside it."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from kr210_sim.errors import IkSpecError
from kr210_sim.exercise.form import find_server, is_ros_form, resolve_spec, seed_scratch

SERVER = "import rospy\nfrom kuka_arm.srv import *\ndef handle_calculate_IK(req):\n    pass\n"
OURS = "import numpy as np\ndef solve(T, q_ref):\n    return None\n"


def write(path: Path, text: str = SERVER) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def test_the_form_is_told_from_the_text(tmp_path: Path) -> None:
    assert is_ros_form(write(tmp_path / "IK_server.py"))
    assert is_ros_form(write(tmp_path / "b.py", "import rospy\nrospy.Service('x', None, f)\n"))
    assert not is_ros_form(write(tmp_path / "ik.py", OURS))
    assert not is_ros_form(
        write(tmp_path / "c.py", "# import rospy\ndef handle_calculate_IK(r): pass\n")
    )
    assert not is_ros_form(tmp_path / "missing.py")


def test_a_repository_its_scripts_folder_or_the_file(tmp_path: Path) -> None:
    repo = tmp_path / "student"
    script = write(repo / "kuka_arm" / "scripts" / "IK_server.py")
    write(repo / "kuka_arm" / "scripts" / "IK_debug.py", "import rospy\n")
    spec = f"{script}:handle_calculate_IK"
    assert resolve_spec(str(repo)) == spec
    assert resolve_spec(str(repo / "kuka_arm" / "scripts")) == spec
    assert resolve_spec(str(script)) == spec
    assert resolve_spec(spec) == spec
    nested = write(tmp_path / "zip" / "catkin_ws" / "src" / "kuka_arm" / "scripts" / "IK_server.py")
    assert find_server(tmp_path / "zip") == nested
    renamed = write(tmp_path / "r" / "scripts" / "my_ik_server.py")
    assert find_server(tmp_path / "r") == renamed
    ours = write(tmp_path / "mine.py", OURS)
    assert resolve_spec(str(ours)) == f"{ours}:solve"
    assert resolve_spec("kr210_sim.robot.kinematics:solve") == "kr210_sim.robot.kinematics:solve"
    long = f"{tmp_path}/{'a' * 300}.py"
    assert resolve_spec(f"{long}:solve") == f"{long}:solve"  # a SPEC is not looked at
    assert resolve_spec(long) == long  # a name too long for the system: nothing to resolve
    (tmp_path / "empty").mkdir()
    with pytest.raises(IkSpecError, match=r"no IK_server.py in this folder"):
        resolve_spec(str(tmp_path / "empty"))


def test_the_files_beside_the_script_are_copied_into_its_working_folder(tmp_path: Path) -> None:
    script = write(tmp_path / "scripts" / "IK_server.py")
    write(tmp_path / "scripts" / "T0_3.pkl", "matrix")
    write(tmp_path / "scripts" / "data" / "dh.csv", "a,b")
    write(tmp_path / "scripts" / "__pycache__" / "x.pyc", "")
    scratch = tmp_path / "scratch"
    write(scratch / "T0_3.pkl", "the script's own")
    assert seed_scratch(script, scratch) == 2
    assert sorted(str(p.relative_to(scratch)) for p in scratch.rglob("*") if p.is_file()) == [
        "IK_server.py",
        "T0_3.pkl",
        "data/dh.csv",
    ]
    assert (scratch / "T0_3.pkl").read_text() == "the script's own"


def test_a_single_file_server_is_seeded_with_itself_alone(tmp_path: Path) -> None:
    """A server handed in as one file of a class folder: its student's files are that file, so
    neither a classmate's ``ik.py`` nor an instructor's 0600 file beside it is copied."""
    script = write(tmp_path / "class" / "alice_server.py")
    write(tmp_path / "class" / "ik.py", OURS)
    key = write(tmp_path / "class" / "key.txt", "secret")
    key.chmod(0o600)
    scratch = tmp_path / "scratch"
    scratch.mkdir()
    assert seed_scratch(script, scratch, root=script) == 1
    assert [p.name for p in scratch.rglob("*")] == ["alice_server.py"]


def test_a_folder_s_files_are_seeded_only_as_its_jail_could_read_them(
    tmp_path: Path,
) -> None:
    """A student folder: its own files that its jail's user could read, not another user's 0600
    file (the copy is the grader's, often root's), not a hard link (it may be anyone's file),
    nothing outside the student's folder."""
    folder = tmp_path / "class" / "bob"
    script = write(folder / "scripts" / "IK_server.py")
    write(folder / "scripts" / "dh.csv", "a,b")
    write(folder / "README.md", "mine")
    write(tmp_path / "class" / "carol" / "ik.py", OURS)
    key = write(tmp_path / "key.txt", "secret")
    key.chmod(0o600)
    os.link(key, folder / "scripts" / "linked.txt")
    write(folder / "scripts" / "mine.txt", "x").chmod(0o600)  # the grader's: the jail's user's
    others = write(folder / "scripts" / "theirs.txt", "x")
    others.chmod(0o600)
    if os.geteuid() == 0:
        os.chown(others, 54321, 54321)  # another user's: the jail's user may not read it
    else:
        others.chmod(0o000)
    scratch = tmp_path / "scratch"
    scratch.mkdir()
    assert seed_scratch(script, scratch, root=folder / "scripts") == 3
    assert sorted(p.name for p in scratch.rglob("*")) == ["IK_server.py", "dh.csv", "mine.txt"]
