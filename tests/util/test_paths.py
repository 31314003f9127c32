"""Where the data lives, and the output-folder helpers' one-line errors."""

from __future__ import annotations

from pathlib import Path

import pytest

from kr210_sim.errors import ConfigError
from kr210_sim.util.outputs import check_folder, write_bytes_atomic
from kr210_sim.util.paths import PACKAGE_DIR, ROOT, find_root


def test_root_holds_the_data() -> None:
    assert (ROOT / "assets" / "kr210" / "kr210.urdf").is_file()
    assert (ROOT / "scenes" / "kr210_cell.xml").is_file()


@pytest.mark.parametrize("value", ["", "  "])
def test_an_empty_root_variable_is_unset(value: str) -> None:
    assert find_root({"KR210_SIM_ROOT": value}) == find_root({})


def test_root_variable_wins(tmp_path: Path) -> None:
    assert find_root({"KR210_SIM_ROOT": str(tmp_path)}) == tmp_path


def test_source_tree_without_shipped_data() -> None:
    # An editable install or a clone: no kr210_sim/assets, so the data is the tree's.
    assert not (PACKAGE_DIR / "assets").exists()
    assert find_root({}) == PACKAGE_DIR.parent


def test_make_out_dir_creates_parents(tmp_path: Path) -> None:
    out = check_folder(tmp_path / "a" / "b")
    assert out.is_dir()
    assert check_folder(out) == out  # an existing folder is fine


@pytest.mark.parametrize(
    ("sub", "message"),
    [("afile", "it is a file, not a folder"), ("afile/x", "cannot create the folder")],
)
def test_make_out_dir_refuses(tmp_path: Path, sub: str, message: str) -> None:
    (tmp_path / "afile").write_text("")
    with pytest.raises(ConfigError, match=message):
        check_folder(tmp_path / sub)


def test_write_bytes_atomic(tmp_path: Path) -> None:
    path = write_bytes_atomic(tmp_path / "f.bin", b"abc")
    assert path.read_bytes() == b"abc"
    (tmp_path / "d").mkdir()
    with pytest.raises(ConfigError, match="it is a folder"):
        write_bytes_atomic(tmp_path / "d", b"x")
    with pytest.raises(ConfigError, match="does not exist"):
        write_bytes_atomic(tmp_path / "missing" / "f.bin", b"x")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d", "f.bin"]
