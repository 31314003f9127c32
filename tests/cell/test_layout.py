"""One source of truth: the runner plans against and scores against the model it simulates."""

from __future__ import annotations

import json
from pathlib import Path

import mujoco
import numpy as np

from kr210_sim.cell.layout import CellLayout, ready_pose
from kr210_sim.cell.load import model_for
from kr210_sim.cell.spec import MotionConfig
from kr210_sim.cli import main
from kr210_sim.score.scoring import in_bin
from kr210_sim.sim.runner import RunConfig, Runner
from kr210_sim.util.paths import MESH_DIR, SCENE_PATH


def _scene_with_bin_moved(dx: float, dy: float) -> mujoco.MjModel:
    """The committed scene with the bin body (walls, floor, drop sites) moved by (dx, dy)."""
    xml = SCENE_PATH.read_text()
    start = xml.index('meshdir="') + len('meshdir="')
    xml = xml[:start] + str(MESH_DIR.resolve()) + xml[xml.index('"', start) :]
    assert '<body name="bin">' in xml
    xml = xml.replace('<body name="bin">', f'<body name="bin" pos="{dx} {dy} 0">')
    return mujoco.MjModel.from_xml_string(xml)


def test_a_bin_moved_in_the_scene_is_the_bin_the_cycle_drops_into_and_is_scored_by() -> None:
    model = _scene_with_bin_moved(0.9, -0.6)
    layout = CellLayout.from_model(model)
    assert layout.bin.center == (0.9, 1.9)
    assert np.allclose(layout.drop_spots[0], (0.9, 1.9))
    runner = Runner(RunConfig(cycles=1), model=model)
    r = runner.run_cycle(1, 5)
    assert r.success, r.detail
    final = np.array(r.target_final)
    assert np.linalg.norm(final[:2] - (0.9, 1.9)) < 0.44  # in the moved bin ...
    assert not in_bin(final, CellLayout.from_model(_scene_with_bin_moved(0, 0)).bin)  # not the old


def test_reports_record_the_cell(tmp_path) -> None:  # type: ignore[no-untyped-def]
    report = tmp_path / "r.json"
    assert main(["run", "--cycles", "1", "--seed", "3", "--report", str(report)]) == 0
    cell = json.loads(report.read_text())["cell"]
    assert cell["name"] == "published" and len(cell["sha256"]) == 64 and cell["slots"] == 9


def test_a_scenes_cell_name_is_shown_escaped_and_bounded() -> None:
    """A hand-made scene's name with a newline, or 50 MB of it, broke the tables."""
    import mujoco

    from kr210_sim.cell.layout import CellLayout
    from kr210_sim.util.paths import SCENE_PATH

    spec = mujoco.MjSpec.from_file(str(SCENE_PATH))
    text = next(t for t in spec.texts if t.name == "cell_name")
    text.data = "two\nlines" + "x" * 100
    name = CellLayout.from_model(spec.compile()).name
    assert name.startswith("two\\nlines") and len(name) == 64 and name.endswith("...")


def test_the_ready_pose_is_the_cells_own_else_the_default(ready_cell: Path) -> None:
    assert np.array_equal(ready_pose(model_for()), MotionConfig().ready_q)
    q = ready_pose(model_for(cell=ready_cell))
    assert np.allclose(np.degrees(q), [40, -15, 20, 0, -5, 0])


def test_view_joints_loads_the_cell_it_is_given(tmp_path: Path) -> None:
    """``view --joints --cell`` ignored the cell (and opened the published one): a missing cell
    file is now refused before any viewer opens."""
    assert main(["view", "--joints", "--cell", str(tmp_path / "missing.toml")]) == 2
