"""A student's files read as hostile input (exercise/files.py): scans that follow no link and
stop at a depth and a count, reads of regular files only, bounded in size."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from kr210_sim.exercise.files import TooLarge, read_head, read_regular, scan


def test_a_scan_follows_no_link_and_stops_at_its_depth_and_count(tmp_path: Path) -> None:
    (tmp_path / "a" / "b" / "c").mkdir(parents=True)
    for rel in ("top.py", "a/one.py", "a/b/two.py", "a/b/c/three.py", "__pycache__/x.pyc"):
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_text(rel)
    (tmp_path / "loop").symlink_to(".")
    (tmp_path / "top_link.py").symlink_to(tmp_path / "top.py")
    os.mkfifo(tmp_path / "pipe.py")
    found = scan(tmp_path, 2, lambda name: name == "__pycache__")
    names = [str(p.relative_to(tmp_path)) for p, _ in found.files]
    assert names == ["top.py", "a/one.py", "a/b/two.py"]
    assert found.complete and found.visited == 10  # 6 at the top, 2 in a, 2 in a/b (c not entered)
    assert scan(tmp_path / "loop", 2).files == []  # the folder itself a link: nothing
    assert scan(tmp_path / "top.py", 2).files == []
    few = scan(tmp_path, 3, limit=4)
    assert not few.complete and few.visited == 5 and len(few.files) <= 4


def test_reads_are_of_regular_files_only_and_bounded(tmp_path: Path) -> None:
    data = tmp_path / "data.txt"
    data.write_bytes(b"x" * 1000)
    assert read_regular(data, 1000) == b"x" * 1000
    with pytest.raises(TooLarge, match="1,000 bytes, more than the 999 read"):
        read_regular(data, 999)
    link = tmp_path / "link.txt"
    link.symlink_to(data)
    with pytest.raises(OSError):
        read_regular(link, 1000)
    assert read_head(link, 10) == b"x" * 10  # a link a user named is followed for the head
    os.mkfifo(tmp_path / "fifo.py")
    for read in (read_regular, read_head):
        with pytest.raises(OSError, match="not a regular file"):
            read(tmp_path / "fifo.py", 10)
    sparse = tmp_path / "sparse.xml"
    with open(sparse, "wb") as f:
        f.truncate(3 << 30)
    with pytest.raises(TooLarge):
        read_regular(sparse, 1 << 20)
