"""Importing the package: MuJoCo's warnings go to logging, not to a file in the current folder."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

#: A free ball thrown at an absurd speed: MuJoCo's step flags the state as unstable and resets it.
UNSTABLE = """
import kr210_sim, mujoco
m = mujoco.MjModel.from_xml_string(
    "<mujoco><worldbody><body><freejoint/><geom size='.1'/></body></worldbody></mujoco>")
d = mujoco.MjData(m)
d.qvel[2] = 1e12
mujoco.mj_step(m, d)
w = d.warning[mujoco.mjtWarning.mjWARN_BADQVEL]
print(w.number, w.lastinfo)
"""


def test_an_unstable_step_is_logged_not_written_to_the_current_folder(tmp_path: Path) -> None:
    proc = subprocess.run(
        [sys.executable, "-c", UNSTABLE], cwd=tmp_path, capture_output=True, text=True, check=True
    )
    assert proc.stdout.split() == ["1", "2"]  # the counter MuJoCo keeps: once, at DOF 2
    assert "Nan, Inf" not in proc.stdout  # MuJoCo's own handler prints it there
    assert "Nan, Inf or huge value in QVEL at DOF 2. The simulation is unstable" in proc.stderr
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()
