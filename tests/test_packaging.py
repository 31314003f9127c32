"""Packaging: a wheel carries the URDF, the meshes and the scene, and runs from any folder."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

#: What a wheel is built from (everything the package ships).
SOURCES = ("pyproject.toml", "setup.py", "README.md", "LICENSE", "kr210_sim", "assets", "scenes")
REPO = Path(__file__).resolve().parents[1]


def _run(argv: list[str], cwd: Path, env: dict[str, str] | None = None) -> str:
    proc = subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True, check=False)
    assert proc.returncode == 0, f"{argv} exited {proc.returncode}:\n{proc.stdout}\n{proc.stderr}"
    return proc.stdout


PIP = [sys.executable, "-m", "pip", "--disable-pip-version-check", "--no-input"]


def _build_wheel(tmp_path: Path, env: dict[str, str] | None = None) -> Path:
    """A wheel built from a copy of the sources (the build leaves nothing in the repository)."""
    src = tmp_path / "src"
    src.mkdir()
    for name in SOURCES:
        if (REPO / name).is_dir():
            shutil.copytree(REPO / name, src / name, ignore=shutil.ignore_patterns("__pycache__"))
        else:
            shutil.copy2(REPO / name, src / name)
    dist = tmp_path / "dist"
    argv = [*PIP, "wheel", "--no-deps", "--no-build-isolation", "-w", str(dist), str(src)]
    _run(argv, tmp_path, env)
    (wheel,) = dist.glob("kr210_sim-*.whl")
    return wheel


def _fresh_venv(tmp_path: Path, wheel: Path) -> tuple[Path, Path]:
    """A fresh venv with ``wheel`` installed: its python and its site-packages.

    The dependencies come from this environment (a path in a .pth file), so the test downloads
    nothing. pip installs the wheel into the venv from outside it."""
    venv = tmp_path / "venv"
    _run([sys.executable, "-m", "venv", "--without-pip", str(venv)], tmp_path)
    python = venv / "bin" / "python"
    site = Path(_run([str(python), "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
                     tmp_path).strip())  # fmt: skip
    deps = {sysconfig.get_path("purelib"), sysconfig.get_path("platlib")}
    (site / "deps.pth").write_text("".join(f"{d}\n" for d in sorted(deps)))
    _run(
        [*PIP, "--python", str(python), "install", "--no-deps", "--no-index", str(wheel)], tmp_path
    )
    return python, site


@pytest.mark.slow
def test_wheel_installed_in_a_fresh_venv_runs_a_cycle_from_another_folder(tmp_path: Path) -> None:
    wheel = _build_wheel(tmp_path)
    names = set(zipfile.ZipFile(wheel).namelist())
    assert {
        "kr210_sim/assets/kr210/kr210.urdf",
        "kr210_sim/assets/kr210/meshes/link_1.stl",
        "kr210_sim/scenes/kr210_cell.xml",
        "kr210_sim/exercise/shims/rospy/__init__.py",
        "kr210_sim/exercise/shims/tf/transformations.py",
        "kr210_sim/exercise/shims/kuka_arm/srv/__init__.py",
        "kr210_sim/schemas/run.schema.json",
        "kr210_sim/schemas/cell.schema.json",
        "kr210_sim/schemas/episode.schema.json",
    } <= names
    assert any(n.startswith("kr210_sim/robot/_ik_native.") and n.endswith(".so") for n in names)
    licence = next(n for n in names if n.endswith(".dist-info/licenses/LICENSE"))
    assert b"MIT License" in zipfile.ZipFile(wheel).read(licence)
    python, site = _fresh_venv(tmp_path, wheel)

    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("KR210_SIM_ROOT", "PYTHONPATH")}
    where = _run(
        [str(python), "-c", "import kr210_sim.util.paths as p; print(p.ROOT)"], elsewhere, env
    )
    assert Path(where.strip()) == site / "kr210_sim"  # the installed copy, not the sources
    native = (
        "from kr210_sim.robot import ik_scalar as s, _ik_native as n; print(s.NATIVE, n.__file__)"
    )
    flag, path = _run([str(python), "-c", native], elsewhere, env).split()
    assert flag == "True" and path.startswith(str(site / "kr210_sim" / "robot"))  # compiled IK
    shims = (  # the ROS modules an original-form IK_server.py imports, from the installed copy
        "import sys; from kr210_sim.exercise.server import SHIMS; sys.path.insert(0, str(SHIMS)); "
        "import rospy, tf.transformations as t, kuka_arm.srv; print(t.__file__)"
    )
    assert _run([str(python), "-c", shims], elsewhere, env).startswith(str(site / "kr210_sim"))
    out = _run([str(python), "-m", "kr210_sim", "run", "--cycles", "1"], elsewhere, env)
    assert "PASS: 1/1" in out
    report = json.loads((elsewhere / "reports" / "run.json").read_text())
    assert report["summary"]["successes"] == 1
    schema = "from kr210_sim.util.schemas import load_schema; print(load_schema('run')['title'])"
    assert _run([str(python), "-c", schema], elsewhere, env).strip() == "kr210_sim run report"

    # An original-form IK_server.py (Python 2, tabs, tf, kuka_arm.srv) graded by the installed
    # copy: its ROS shims and Python 2 reading come from the wheel.
    sys.path.insert(0, str(REPO / "tests"))
    import ros_class

    ros_class.write_class(elsewhere / "class", ("alice",))
    argv = ["grade", "class", "--cases", "5", "--cycles", "1", "--report", "grade.json"]
    _run([str(python), "-m", "kr210_sim", *argv], elsewhere, env)
    (student,) = json.loads((elsewhere / "grade.json").read_text())["students"]
    assert student["verdict"] == "pass", student["detail"]
    assert student["spec"].endswith("alice/kuka_arm/scripts/IK_server.py:handle_calculate_IK")


@pytest.mark.slow
def test_an_install_without_a_c_compiler_solves_in_pure_python(tmp_path: Path) -> None:
    """The compiled IK is optional: a build whose compiler fails ships no extension, and the
    installed package takes the pure-Python path with the same answers."""
    env = {**os.environ, "CC": "false"}  # a compiler that fails on every file
    wheel = _build_wheel(tmp_path, env)
    assert not any(n.endswith(".so") for n in zipfile.ZipFile(wheel).namelist())
    python, _ = _fresh_venv(tmp_path, wheel)
    code = (
        "import numpy as np; from kr210_sim.robot import ik_scalar as s, kinematics as k; "
        "q = np.array([0.3, 0.2, -0.4, 1.0, 0.7, -0.5]); sols = k.inverse(k.forward(q)); "
        "print(s.NATIVE, s.inverse_one.__name__, len(sols), np.abs(sols - q).max(axis=1).min())"
    )
    clean = {k: v for k, v in os.environ.items() if k not in ("KR210_SIM_PURE_IK", "PYTHONPATH")}
    native, name, n, miss = _run([str(python), "-c", code], tmp_path, clean).split()
    assert (native, name) == ("False", "inverse_one_py")
    assert int(n) >= 2 and float(miss) < 1e-9  # the pose's own q among its solutions
