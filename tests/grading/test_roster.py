"""SUBMISSION arguments to named students (grading/roster.py): folders, files, SPECs, and the
entries of a class folder that look like a submission but cannot be graded."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from kr210_sim.errors import ConfigError, Kr210SimError
from kr210_sim.grading.roster import Student, find_students

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "ik_dh.py"


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
    # Each with its own files, the root its jail shows it: a folder student its folder, a
    # file (in the class folder, or a SPEC's) the file alone, never the folder beside it.
    assert found == [
        Student("alice", f"{tmp_path}/alice.py:solve", root=f"{tmp_path}/alice.py"),
        Student("bob", f"{bob}/ik.py:solve", root=str(bob)),
        Student("carol", f"{carol}/my_solution.py:solve", root=str(carol)),
        Student("dave", "", f"no ik.py in {dave} (2 .py files)"),
        Student("ik_dh", f"{EXAMPLE}:nearest", root=str(EXAMPLE)),
    ]
    with pytest.raises(ConfigError, match="two students named 'alice'"):
        find_students([str(tmp_path), str(tmp_path / "alice.py")])
    assert find_students([tmp_path / "alice.py", "kr210_sim.robot.kinematics:nearest"]) == [
        Student("alice", f"{tmp_path}/alice.py:solve", root=f"{tmp_path}/alice.py"),
        Student("kr210_sim.robot.kinematics", "kr210_sim.robot.kinematics:nearest"),
    ]


def test_what_looks_like_a_submission_is_a_student_that_says_what_to_do(tmp_path: Path) -> None:
    """A link to nothing, a .PY file and a notebook were left out of the class without a word."""
    (tmp_path / "alice.py").write_text("")
    (tmp_path / "dangling.py").symlink_to("nonexistent.py")
    (tmp_path / "BOB.PY").write_text("")
    (tmp_path / "carol.ipynb").write_text("{}")
    (tmp_path / "alice.ipynb").write_text("{}")  # beside its export: both are listed
    (tmp_path / "notes.txt").symlink_to("nowhere.txt")  # not a submission's name
    erin = tmp_path / "erin"
    erin.mkdir()
    (erin / "work.ipynb").write_text("{}")
    fred = tmp_path / "fred"
    fred.mkdir()
    (fred / "ik.py").symlink_to("../gone.py")
    found = {s.name: s for s in find_students([str(tmp_path)])}
    names = ["BOB.PY", "alice", "alice.ipynb", "carol.ipynb", "dangling", "erin", "fred"]
    assert sorted(found) == names
    assert found["alice"].spec and not found["alice"].problem
    assert found["dangling"] == Student(
        "dangling",
        "",
        f"{tmp_path}/dangling.py is a symbolic link to nonexistent.py, which does not exist",
    )
    assert found["BOB.PY"].problem == (
        f"{tmp_path}/BOB.PY ends in '.PY': Python imports only files ending in '.py'; rename it "
        "BOB.py"
    )
    assert found["carol.ipynb"].problem == (
        f"{tmp_path}/carol.ipynb is a Jupyter notebook: export its code as a .py file "
        "(jupyter nbconvert --to script carol.ipynb) and grade that"
    )
    assert found["erin"].problem.startswith(
        f"no ik.py in {erin} (no .py file; {erin}/work.ipynb is a Jupyter notebook"
    )
    assert (
        found["fred"].problem
        == f"{fred}/ik.py is a symbolic link to ../gone.py, which does not exist"
    )
    # Given alone, each is refused in one line that says the same.
    for name, why in (
        ("carol.ipynb", "is a Jupyter notebook: export its code"),
        ("BOB.PY", "rename it BOB.py"),
        ("dangling.py", "is a symbolic link to nonexistent.py"),
    ):
        with pytest.raises(ConfigError, match=why):
            find_students([str(tmp_path / name)])


def test_a_spec_that_names_no_py_file_is_refused_and_touches_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``/x/victim:solve`` named the student by the whole path, and the grader's temporary
    files overwrote victim.err and victim.json beside it."""
    (tmp_path / "c3").mkdir()
    (tmp_path / "c3" / "victim.err").write_text("precious data")
    (tmp_path / "c3" / "near.py").write_text("")
    monkeypatch.chdir(tmp_path)
    for spec, why in (
        (f"{tmp_path}/c3/victim:solve", f"{tmp_path}/c3/victim is not a .py file; a SPEC is"),
        ("c3/victim:solve", "c3/victim is not a .py file"),
        ("c3/near:solve", "(did you mean c3/near.py:solve?)"),
        ("c3/sub/x.txt:solve", "c3/sub/x.txt is not a .py file"),
        ("..:solve", "'..' is neither a .py file nor a module name"),
        ("a-b:solve", "'a-b' is neither a .py file nor a module name"),
        ("c3/gone.py:solve", "no such file c3/gone.py"),
    ):
        with pytest.raises(ConfigError) as info:
            find_students([spec])
        assert why in str(info.value) and len(str(info.value).splitlines()) == 1
    with pytest.raises(Kr210SimError, match=r"expected package\.module:function"):
        find_students(["c3/near.py:"])
    assert sorted(p.name for p in (tmp_path / "c3").iterdir()) == ["near.py", "victim.err"]
    assert (tmp_path / "c3" / "victim.err").read_text() == "precious data"


def test_odd_file_names_become_printable_distinct_names(tmp_path: Path) -> None:
    raw = os.fsencode(tmp_path) + b"/bad\xffname.py"
    Path(os.fsdecode(raw)).write_text("")
    (tmp_path / "new\nline.py").write_text("")
    (tmp_path / ("a" * 250 + ".py")).write_text("")
    (tmp_path / "x.py").write_text("")
    (tmp_path / "x.job.py").write_text("")
    found = find_students([str(tmp_path)])
    assert [s.name for s in found] == ["a" * 250, "bad\\xffname", "new\\nline", "x.job", "x"]
    assert os.fsencode(found[1].spec) == raw + b":solve"  # the file itself, to import
    with pytest.raises(ConfigError, match="must be a list of paths"):
        find_students(str(tmp_path))  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="no submission"):
        find_students([])


def test_repositories_of_the_original_exercise_are_students(tmp_path: Path) -> None:
    """A class folder of repositories: one student per repository, graded by its server's
    handle_calculate_IK; one repository named alone is one student; a .py file that is a ROS
    server is graded by its handler."""
    server = "import rospy\nfrom kuka_arm.srv import *\ndef handle_calculate_IK(req):\n    pass\n"
    for name in ("ann", "ben"):
        path = tmp_path / "class" / name / "kuka_arm" / "scripts" / "IK_server.py"
        path.parent.mkdir(parents=True)
        path.write_text(server)
    (tmp_path / "class" / "cid.py").write_text(server)
    (tmp_path / "class" / "dee.py").write_text("def solve(T, q):\n    return None\n")
    students = find_students([str(tmp_path / "class")])
    assert [(s.name, s.spec, s.root) for s in students] == [
        (
            "ann",
            f"{tmp_path}/class/ann/kuka_arm/scripts/IK_server.py:handle_calculate_IK",
            f"{tmp_path}/class/ann",
        ),
        (
            "ben",
            f"{tmp_path}/class/ben/kuka_arm/scripts/IK_server.py:handle_calculate_IK",
            f"{tmp_path}/class/ben",
        ),
        ("cid", f"{tmp_path}/class/cid.py:handle_calculate_IK", f"{tmp_path}/class/cid.py"),
        ("dee", f"{tmp_path}/class/dee.py:solve", f"{tmp_path}/class/dee.py"),
    ]
    (alone,) = find_students([str(tmp_path / "class" / "ann")])
    assert alone.name == "ann" and alone.spec == students[0].spec and alone.root == students[0].root


def test_a_submission_file_that_leads_out_of_its_folder_is_not_graded(tmp_path: Path) -> None:
    """Inside a student's folder, a server, an ik.py or a lone .py file that is a symbolic link
    out of that folder (or sits in a linked folder) is an error student that says where it
    leads: its jail would not show it the file, and its working folder would be seeded with the
    files beside what the link leads to. A link that stays inside the folder is graded."""
    outside = tmp_path / "outside"
    outside.mkdir()
    server = "import rospy\nfrom kuka_arm.srv import *\ndef handle_calculate_IK(req):\n    pass\n"
    (outside / "IK_server.py").write_text(server)
    (outside / "ik.py").write_text("def solve(T, q):\n    return q\n")
    klass = tmp_path / "class"
    (klass / "ann" / "kuka_arm" / "scripts").mkdir(parents=True)
    (klass / "ann" / "kuka_arm" / "scripts" / "IK_server.py").symlink_to(outside / "IK_server.py")
    (klass / "ben" / "kuka_arm").mkdir(parents=True)
    (klass / "ben" / "kuka_arm" / "scripts").symlink_to(outside)
    (klass / "cid").mkdir()
    (klass / "cid" / "ik.py").symlink_to(outside / "ik.py")
    (klass / "dee").mkdir()
    (klass / "dee" / "mine.py").symlink_to(outside / "ik.py")
    (klass / "eve" / "src").mkdir(parents=True)
    (klass / "eve" / "src" / "ik.py").write_text("def solve(T, q):\n    return q\n")
    (klass / "eve" / "ik.py").symlink_to(klass / "eve" / "src" / "ik.py")  # stays inside
    students = {s.name: s for s in find_students([str(klass)])}
    for name, file, to in (
        ("ann", "kuka_arm/scripts/IK_server.py", "IK_server.py"),
        ("ben", "kuka_arm/scripts/IK_server.py", "IK_server.py"),
        ("cid", "ik.py", "ik.py"),
        ("dee", "mine.py", "ik.py"),
    ):
        assert students[name].spec == "" and students[name].problem == (
            f"{klass / name / file} leads out of its student's folder {klass / name}, to "
            f"{outside / to} (a symbolic link): not graded (copy the file into the folder)"
        )
    assert (
        students["eve"].spec == f"{klass / 'eve' / 'ik.py'}:solve" and not students["eve"].problem
    )


def test_a_folder_of_link_loops_is_scanned_in_a_bounded_number_of_steps(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """200 links ``lNNN -> .`` in a student's folder: the server search follows none of them
    (a 4-level glob through them opened 200**3 folders)."""
    loops = tmp_path / "class" / "loops"
    loops.mkdir(parents=True)
    for i in range(200):
        (loops / f"l{i:03d}").symlink_to(".")
    (loops / "notes.txt").write_text("")
    (tmp_path / "class" / "alice.py").write_text(EXAMPLE.read_text())
    opened = []
    real = os.scandir

    def counted(path: object = ".") -> object:
        opened.append(path)
        if len(opened) > 1000:
            raise RuntimeError("more than 1000 folders opened")
        return real(path)  # type: ignore[arg-type]

    monkeypatch.setattr(os, "scandir", counted)
    found = find_students([str(tmp_path / "class")])
    assert [s.name for s in found] == ["alice", "loops"]
    assert found[1].problem.startswith("no ik.py in")
    assert len(opened) < 20


def test_a_fifo_named_like_a_script_does_not_block_the_start_up(tmp_path: Path) -> None:
    """A FIFO ``scripts/IK_helper.py``: the roster reads only regular files (it opened this
    one and waited for a writer forever)."""
    student = tmp_path / "class" / "fifo"
    (student / "scripts").mkdir(parents=True)
    os.mkfifo(student / "scripts" / "IK_helper.py")
    (tmp_path / "class" / "alice.py").write_text(EXAMPLE.read_text())
    code = (
        "import sys; from kr210_sim.grading.roster import find_students; "
        "print(sorted(s.name for s in find_students([sys.argv[1]])))"
    )
    done = subprocess.run(
        [sys.executable, "-c", code, str(tmp_path / "class")],
        capture_output=True,
        text=True,
        timeout=60,
        env=dict(os.environ, PYTHONPATH=str(ROOT)),
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "['alice', 'fifo']"
