"""Output files: links written through, devices never replaced, umask respected, clashes refused."""

from __future__ import annotations

import json
import os
import socket
import stat
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from kr210_sim.errors import ConfigError
from kr210_sim.util.outputs import (
    atomic_path,
    check_distinct,
    check_folder,
    check_writable,
    write_json_atomic,
)


@pytest.fixture
def umask() -> Iterator[None]:
    old = os.umask(0o022)
    yield
    os.umask(old)


def test_a_link_is_written_through_and_stays_a_link(tmp_path: Path) -> None:
    target = tmp_path / "real.json"
    target.write_text("{}")
    link = tmp_path / "link.json"
    link.symlink_to(target)
    write_json_atomic(link, {"a": 1})
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert json.loads(target.read_text()) == {"a": 1}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.json", "real.json"]


def test_a_dangling_link_creates_its_target(tmp_path: Path) -> None:
    link = tmp_path / "link.json"
    link.symlink_to(tmp_path / "new.json")
    write_json_atomic(link, {"b": 2})
    assert link.is_symlink() and json.loads((tmp_path / "new.json").read_text()) == {"b": 2}


def test_a_character_device_is_written_through_not_replaced(tmp_path: Path) -> None:
    null = tmp_path / "null"
    try:  # a private copy of /dev/null (needs root): the real one is never put at risk
        os.mknod(null, stat.S_IFCHR | 0o666, os.makedev(1, 3))
    except PermissionError:
        pytest.skip("creating a device node needs root")
    write_json_atomic(null, {"c": 3})
    assert stat.S_ISCHR(os.stat(null).st_mode)
    assert list(tmp_path.iterdir()) == [null]


def test_a_fifo_is_written_through(tmp_path: Path) -> None:
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    got: list[str] = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_text()))
    reader.start()
    write_json_atomic(fifo, {"d": 4})
    reader.join(10)
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)
    assert json.loads(got[0]) == {"d": 4}


def test_a_socket_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "sock"
    with socket.socket(socket.AF_UNIX) as s:
        s.bind(str(path))
        with pytest.raises(ConfigError, match="not a regular file"):
            check_writable(path)


def test_new_files_follow_the_umask(tmp_path: Path, umask: None) -> None:
    write_json_atomic(tmp_path / "a.json", {})
    assert stat.S_IMODE(os.stat(tmp_path / "a.json").st_mode) == 0o644
    os.umask(0o027)
    write_json_atomic(tmp_path / "b.json", {})
    assert stat.S_IMODE(os.stat(tmp_path / "b.json").st_mode) == 0o640


def test_a_replaced_file_keeps_its_mode(tmp_path: Path, umask: None) -> None:
    path = tmp_path / "a.json"
    path.write_text("{}")
    path.chmod(0o600)
    write_json_atomic(path, {"e": 5})
    assert stat.S_IMODE(os.stat(path).st_mode) == 0o600


def test_a_failed_write_leaves_the_old_file(tmp_path: Path) -> None:
    path = tmp_path / "video.mp4"
    path.write_bytes(b"good")
    with pytest.raises(RuntimeError), atomic_path(path) as tmp:
        tmp.write_bytes(b"half")
        raise RuntimeError("encoder died")
    assert path.read_bytes() == b"good"
    assert list(tmp_path.iterdir()) == [path]


def test_clashing_outputs_and_inputs_are_refused(tmp_path: Path) -> None:
    a = tmp_path / "a.json"
    check_distinct({"--report": a, "--video": tmp_path / "v.mp4"})
    with pytest.raises(ConfigError, match="--video and --report name the same file"):
        check_distinct({"--report": a, "--video": tmp_path / "x" / ".." / "a.json"})
    with pytest.raises(ConfigError, match="--report and --scene name the same file"):
        check_distinct({"--report": a}, {"--scene": a})
    link = tmp_path / "link.json"
    link.symlink_to(a)
    with pytest.raises(ConfigError, match="same file"):
        check_distinct({"--report": link, "--video": a})
    check_distinct({"--report": Path(os.devnull), "--video": Path(os.devnull)})  # both discarded


def test_a_folder_for_files(tmp_path: Path) -> None:
    assert check_folder(tmp_path / "new" / "plots", ("a.png",)).is_dir()
    (tmp_path / "p" / "a.png").mkdir(parents=True)
    with pytest.raises(ConfigError, match="is a folder"):
        check_folder(tmp_path / "p", ("a.png",))
    (tmp_path / "f").write_text("")
    with pytest.raises(ConfigError, match="it is a file"):
        check_folder(tmp_path / "f", ())
