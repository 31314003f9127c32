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
SOURCES = ("pyproject.toml", "README.md", "LICENSE", "kr210_sim", "assets", "scenes")
REPO = Path(__file__).resolve().parents[1]


def _run(argv: list[str], cwd: Path, env: dict[str, str] | None = None) -> str:
    proc = subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True, check=False)
    assert proc.returncode == 0, f"{argv} exited {proc.returncode}:\n{proc.stdout}\n{proc.stderr}"
    return proc.stdout


@pytest.mark.slow
def test_wheel_installed_in_a_fresh_venv_runs_a_cycle_from_another_folder(tmp_path: Path) -> None:
    # Build from a copy of the sources, so the build leaves nothing in the repository.
    src = tmp_path / "src"
    src.mkdir()
    for name in SOURCES:
        if (REPO / name).is_dir():
            shutil.copytree(REPO / name, src / name, ignore=shutil.ignore_patterns("__pycache__"))
        else:
            shutil.copy2(REPO / name, src / name)
    dist = tmp_path / "dist"
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check", "--no-input"]
    _run([*pip, "wheel", "--no-deps", "--no-build-isolation", "-w", str(dist), str(src)], tmp_path)
    (wheel,) = dist.glob("kr210_sim-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    assert {
        "kr210_sim/assets/kr210/kr210.urdf",
        "kr210_sim/assets/kr210/meshes/link_1.stl",
        "kr210_sim/scenes/kr210_cell.xml",
        "kr210_sim/robot/ros/shims/rospy/__init__.py",
        "kr210_sim/robot/ros/shims/tf/transformations.py",
        "kr210_sim/robot/ros/shims/kuka_arm/srv/__init__.py",
    } <= names
    assert any(n.startswith("kr210_sim/robot/_ik_native.") and n.endswith(".so") for n in names)
    licence = next(n for n in names if n.endswith(".dist-info/licenses/LICENSE"))
    assert b"MIT License" in zipfile.ZipFile(wheel).read(licence)

    # A fresh venv; the dependencies come from this environment (a path in a .pth file), so the
    # test downloads nothing. pip installs the wheel into the venv from outside it.
    venv = tmp_path / "venv"
    _run([sys.executable, "-m", "venv", "--without-pip", str(venv)], tmp_path)
    python = venv / "bin" / "python"
    site = Path(_run([str(python), "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
                     tmp_path).strip())  # fmt: skip
    deps = {sysconfig.get_path("purelib"), sysconfig.get_path("platlib")}
    (site / "deps.pth").write_text("".join(f"{d}\n" for d in sorted(deps)))
    _run(
        [*pip, "--python", str(python), "install", "--no-deps", "--no-index", str(wheel)], tmp_path
    )

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
        "import sys; from kr210_sim.robot.ros.server import SHIMS; sys.path.insert(0, str(SHIMS)); "
        "import rospy, tf.transformations as t, kuka_arm.srv; print(t.__file__)"
    )
    assert _run([str(python), "-c", shims], elsewhere, env).startswith(str(site / "kr210_sim"))
    out = _run([str(python), "-m", "kr210_sim", "run", "--cycles", "1"], elsewhere, env)
    assert "PASS: 1/1" in out
    report = json.loads((elsewhere / "reports" / "run.json").read_text())
    assert report["summary"]["successes"] == 1

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
