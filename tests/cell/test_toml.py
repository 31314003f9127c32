"""Cell files: the published one, a grid of other shapes, and every kind of bad file."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import mujoco
import numpy as np
import pytest

from kr210_sim.cell.layout import CellLayout
from kr210_sim.cell.load import compile_cell, load_model, model_for
from kr210_sim.cell.toml import PUBLISHED_CELL, load_cell, parse_cell
from kr210_sim.cli import main
from kr210_sim.errors import ConfigError

PUBLISHED = PUBLISHED_CELL.read_text()


def _with(old: str, new: str) -> str:
    assert old in PUBLISHED, old
    return PUBLISHED.replace(old, new, 1)


def test_published_cell_compiles_to_the_committed_scene() -> None:
    a = CellLayout.from_model(compile_cell(load_cell(PUBLISHED_CELL)))
    b = CellLayout.from_model(load_model())
    assert a.layout_sha256 == b.layout_sha256
    assert (a.name, b.name) == ("published", "published")
    assert a.sha256 == b.sha256 == load_cell(PUBLISHED_CELL).sha256
    assert np.allclose(b.slots[0], (2.6, 0.9, 0.789)) and np.allclose(
        b.slots[8], (2.6, -0.9, 2.322)
    )
    assert b.bin.center == (0.0, 2.5) and b.bin.inner_half == (0.44, 0.44)
    assert (b.bin.floor_top, b.bin.rim) == pytest.approx((0.05, 1.0))
    assert len(b.drop_spots) == 9 and np.allclose(b.drop_spots[1], (0.22, 2.5))
    assert b.randomization.yaw == (-np.pi, np.pi)


def test_a_4x2_shelf_turned_to_face_the_robot_from_behind() -> None:
    text = _with("position = [2.7, 0.0]", "position = [-2.7, 0.5]")
    text = text.replace("yaw_deg = 0.0 ", "yaw_deg = 180.0 ").replace("rows = 3", "rows = 4")
    text = text.replace("columns = 3", "columns = 2").replace(
        "column_pitch = 0.9", "column_pitch = 0.7"
    )
    text = text.replace("row_pitch = [0.767, 0.766]", "row_pitch = 0.5").replace(
        "bottom = 0.789", "bottom = 0.6"
    )
    cell = parse_cell(text, "turned.toml")
    layout = CellLayout.from_model(compile_cell(cell))
    assert layout.n_slots == 8
    # seen from the robot (looking along -x), left is -y: slot 1 bottom left, slot 2 its right
    assert np.allclose(layout.slots[0], (-2.6, 0.5 - 0.35, 0.6))
    assert np.allclose(layout.slots[1], (-2.6, 0.5 + 0.35, 0.6))
    assert np.allclose(layout.slots[7], (-2.6, 0.5 + 0.35, 2.1))
    assert np.allclose(layout.shelf.local((-2.49, 0.5, 1.0))[:2], (-0.21, 0.0), atol=1e-9)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (_with("rows = 3\n", ""), "[shelf] rows: missing (required)"),
        (_with("rows = 3", 'rows = "three"'), "[shelf] rows: expected a whole number from 1 to 5"),
        (_with("rows = 3", "rows = 6"), "[shelf] rows: expected a whole number from 1 to 5, got 6"),
        (
            _with("size = [1.0, 1.0, 1.0]", "size = [1.0, -1.0, 1.0]"),
            "[bin] size: expected a list of 3 positive numbers",
        ),
        (_with("depth = 0.42", "depth = -0.42"), "[shelf] depth: expected a positive number"),
        (_with("position = [0.0, 2.5]", "position = [2.5, 0.5]"), "footprints overlap"),
        (_with("position = [2.7, 0.0]", "position = [0.5, 0.0]"), "reaches into the robot's base"),
        (
            PUBLISHED + "\n[[obstacles]]\nposition = [0.3, 0.0, 0.5]\nsize = [0.2, 0.2, 1.0]\n",
            "[[obstacles]] #1 position: expected the box clear of the robot's base",
        ),
        (  # an obstacle that fills the bin: every cycle would end missed_bin
            PUBLISHED + "\n[[obstacles]]\nposition = [0.0, 2.5, 0.5]\nsize = [0.7, 0.7, 0.9]\n",
            "[[obstacles]] #1 position: expected the box out of the bin's inside",
        ),
        (  # a box standing in the shelf's slots
            PUBLISHED + "\n[[obstacles]]\nposition = [2.6, 0.0, 1.0]\nsize = [0.2, 0.2, 0.2]\n",
            "[[obstacles]] #1 position: expected the box out of the shelf",
        ),
        (
            _with("row_pitch = [0.767, 0.766]", "row_pitch = [0.767]"),
            "[shelf] row_pitch: expected a positive number or a list of 2",
        ),
        (  # a compartment lower than the target: it spawned 45 mm inside the board above
            _with("row_pitch = [0.767, 0.766]", "row_pitch = 0.2"),
            "[shelf] row_pitch: expected more than 0.330 m between board tops (the 0.25 m "
            "target, a 0.04 m board and the 0.04 m lift), got 0.2",
        ),
        (
            _with("height = 3.0", "height = 2.65"),
            "[shelf] height: expected more than 2.652 m (the top board's top 2.322 m + the "
            "0.25 m target, a 0.04 m board and the 0.04 m lift), got 2.65",
        ),
        (  # the nominal target fits, the longest drawn with --randomize does not
            _with("row_pitch = [0.767, 0.766]", "row_pitch = [0.767, 0.35]"),
            "[target.randomize] length: expected a high end below 0.270 m (the lowest "
            "compartment's 0.350 m less a 0.04 m board and the 0.04 m lift), got [0.2, 0.3]",
        ),
        (  # a cylinder standing on the floor would have its centre above the rim: missed_bin
            _with("size = [1.0, 1.0, 1.0]", "size = [1.0, 1.0, 0.28]").replace(
                "length = 0.25", "length = 0.5"
            ),
            "[bin] size: expected a rim above 0.300 m (the floor's top 0.05 m + half the 0.5 m "
            "target: standing on the floor, a cylinder counts only with its centre below the "
            "rim), got [1.0, 1.0, 0.28]",
        ),
        (
            _with("size = [1.0, 1.0, 1.0]", "size = [1.0, 1.0, 0.28]").replace(
                "length = [0.20, 0.30]", "length = [0.2, 0.5]"
            ),
            "[target.randomize] length: expected a high end below 0.460 m (twice the bin's "
            "depth, rim 0.28 m less floor 0.05 m: standing on the floor",
        ),
        (_with("[bin]", "[bin]\ncolour = 'red'"), "[bin] has an unknown key 'colour'"),
        (_with("name =", "name = = "), "not valid TOML"),
        (
            _with("mass = [0.02, 0.5]", "mass = [0.5, 0.02]"),
            "[target.randomize] mass: expected [low, high]",
        ),
        # Every size is bounded (a 1e300 m shelf hung every compile), and nothing MuJoCo would
        # reject gets through to it: the message names the key and the bound.
        (
            _with("height = 3.0", "height = 1e300"),
            "[shelf] height: expected a positive number [m] from 0.001 to 20, got 1e+300",
        ),
        (
            _with("radius = 0.05", "radius = 1e-300"),
            "[target] radius: expected a positive number [m] from 0.001 to 20, got 1e-300",
        ),
        (
            _with("position = [2.7, 0.0]", "position = [1e300, 0.0]"),
            "[shelf] position: expected a list of 2 numbers [m], each from -20 to 20",
        ),
        (
            _with("mass = 0.05", "mass = 1e200"),
            "[target] mass: expected a positive number [kg] from 0.0001 to 100",
        ),
        (
            _with("radius = [0.04, 0.06]", "radius = [0.0, 0.06]"),
            "[target.randomize] radius: expected [low, high] with 0.001 <= low <= high <= 20",
        ),
        (
            _with('name = "published"', 'name = "published"\n[robot]\nready_q = [45, 0, 0]'),
            "[robot] ready_q: expected a list of 6 joint angles within +-360 [deg], got [45, 0, 0]",
        ),
        (  # within +-360 but past the URDF's joint limits: named, with the limits
            _with(
                'name = "published"', 'name = "published"\n[robot]\nready_q = [0, 0, 0, 0, 0, 355]'
            ),
            "[robot] ready_q: joint_6 = 355 deg is outside its limits [-350, 350] deg",
        ),
        (
            _with(
                'name = "published"', 'name = "published"\n[robot]\nready_q = [-190, 0, 0, 0, 0, 0]'
            ),
            "[robot] ready_q: joint_1 = -190 deg is outside its limits [-185, 185] deg",
        ),
        (
            _with('name = "published"', 'name = "published"\n[robot]\nready = [0, 0, 0]'),
            "[robot] has an unknown key 'ready' (keys: ready_q)",
        ),
        (
            _with('name = "published"', 'name = "two\\nlines"'),
            "name: expected 1 to 64 printable characters",
        ),
        (
            _with('name = "published"', 'name = "' + "x" * 100 + '"'),
            "name: expected 1 to 64 printable characters without leading or trailing spaces, "
            "got '" + "x" * 64 + "'...",
        ),
    ],
)
def test_bad_cell_files_are_one_line_and_exit_2(
    tmp_path: Path, text: str, message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=None) as exc:
        load_cell(path)
    assert str(exc.value).startswith(f"{path}: ") and message in str(exc.value)
    assert (
        main(["run", "--cycles", "1", "--cell", str(path), "--report", str(tmp_path / "r.json")])
        == 2
    )
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err
    assert not (tmp_path / "r.json").exists()


def test_the_ready_pose_comes_from_the_cell_file_in_degrees() -> None:
    text = PUBLISHED_CELL.read_text().replace(
        'name = "published"', 'name = "ready"\n[robot]\nready_q = [30, -10, 15, 0, 5, 0]'
    )
    cell = parse_cell(text)
    assert cell.ready_q_deg == (30.0, -10.0, 15.0, 0.0, 5.0, 0.0)
    layout = CellLayout.from_model(compile_cell(cell))
    assert layout.ready_q is not None
    assert np.allclose(np.degrees(layout.ready_q), [30, -10, 15, 0, 5, 0])
    assert CellLayout.from_model(load_model()).ready_q is None  # the published cell sets none


def test_one_row_with_an_empty_row_pitch_list_loads() -> None:
    text = _with("rows = 3", "rows = 1").replace("row_pitch = [0.767, 0.766]", "row_pitch = []")
    cell = parse_cell(text, "one_row.toml")
    assert cell.shelf.rows == 1 and cell.shelf.row_pitch == ()


def test_a_fifo_or_a_huge_file_as_cell_is_refused_without_blocking(tmp_path: Path) -> None:
    import os
    import threading

    fifo = tmp_path / "cell.toml"
    os.mkfifo(fifo)
    errors: list[str] = []

    def load() -> None:
        try:
            load_cell(fifo)
        except ConfigError as exc:
            errors.append(str(exc))

    worker = threading.Thread(target=load, daemon=True)
    worker.start()
    worker.join(timeout=10)
    if worker.is_alive():  # it blocked in open(): give it a writer so the test ends
        with open(fifo, "w") as fh:
            fh.write("")
        worker.join(timeout=10)
        pytest.fail("load_cell blocked on a FIFO")
    assert errors == [f"cell file {fifo} is a FIFO, not a regular file: give a file"]
    huge = tmp_path / "huge.toml"
    huge.write_text('name = "' + "x" * 2_000_000 + '"\n' + PUBLISHED.split("\n", 4)[-1])
    with pytest.raises(ConfigError, match="is larger than 1,000,000 bytes"):
        load_cell(huge)


def test_cell_file_errors_for_the_file_itself(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["run", "--cell", str(tmp_path / "none.toml")]) == 2
    assert "cell file not found" in capsys.readouterr().err
    assert main(["run", "--cell", str(PUBLISHED_CELL), "--scene", "scenes/kr210_cell.xml"]) == 2
    assert "not both" in capsys.readouterr().err
    assert main(["run", "--cell", str(tmp_path), "--report", str(tmp_path / "r.json")]) == 2
    assert "is a folder" in capsys.readouterr().err


def test_the_cell_file_is_a_protected_input(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cell = tmp_path / "mine.toml"
    cell.write_text(PUBLISHED)
    assert main(["run", "--cycles", "1", "--cell", str(cell), "--report", str(cell)]) == 2
    assert "--cell" in capsys.readouterr().err
    assert cell.read_text() == PUBLISHED


def test_slot_numbers_follow_the_cell(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    small = tmp_path / "small.toml"
    text = _with("rows = 3", "rows = 1").replace('name = "published"', 'name = "small"')
    small.write_text("\n".join(x for x in text.splitlines() if "row_pitch" not in x))
    assert CellLayout.from_model(model_for(cell=small)).n_slots == 3
    assert (
        main(
            [
                "run",
                "--cycles",
                "1",
                "--slot",
                "4",
                "--cell",
                str(small),
                "--report",
                str(tmp_path / "r.json"),
            ]
        )
        == 2
    )
    assert "slot must be 0 (random) or 1-3 in cell 'small'" in capsys.readouterr().err
    assert main(["run", "--slot", "10", "--report", str(tmp_path / "r.json")]) == 2
    assert "1-9 in cell 'published'" in capsys.readouterr().err


def test_compiled_cells_are_cached_and_copied() -> None:
    cell = load_cell(PUBLISHED_CELL)
    assert compile_cell(cell) is compile_cell(dataclasses.replace(cell))
    a, b = model_for(cell=PUBLISHED_CELL), model_for(cell=PUBLISHED_CELL)
    a.geom_friction[0, 0] = 9.0
    assert b.geom_friction[0, 0] != 9.0
    assert mujoco.mj_name2id(a, mujoco.mjtObj.mjOBJ_SITE, "slot_9") >= 0


def test_a_fifo_as_scene_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import os

    fifo = tmp_path / "scene.xml"
    os.mkfifo(fifo)
    assert main(["check", "--scene", str(fifo)]) == 2
    assert "is not a regular file (a FIFO or a device)" in capsys.readouterr().err
