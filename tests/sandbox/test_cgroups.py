"""Control groups for the jail (sandbox/cgroups.py): where they can be made, and what they hold."""

from __future__ import annotations

import contextlib
import os
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest
from memory_hog import hog

from kr210_sim.sandbox import cgroups
from kr210_sim.sandbox.cgroups import Limiter, Mount, find_place, mounts, own_groups

MOUNTINFO = """\
31 23 0:28 / /sys/fs/cgroup rw,relatime - tmpfs tmpfs rw,mode=755
32 31 0:29 / /sys/fs/cgroup/cpu rw,relatime - cgroup cgroup rw,cpu
33 31 0:30 / /sys/fs/cgroup/cpu\\040acct rw,relatime - cgroup cgroup rw,cpuacct
39 31 0:36 /docker/abc /sys/fs/cgroup/pids rw,relatime - cgroup cgroup rw,pids
41 31 0:38 / /sys/fs/cgroup/unified rw,relatime - cgroup2 cgroup2 rw
"""
CGROUP = "8:pids:/docker/abc\n2:cpu:/\n0::/user.slice/app.scope\n"


def test_the_hierarchies_and_own_groups_are_read_from_procs_text() -> None:
    found = mounts(MOUNTINFO)
    assert [(m.version, sorted(m.options), m.root, str(m.point)) for m in found] == [
        (1, ["cpu", "rw"], "/", "/sys/fs/cgroup/cpu"),
        (1, ["cpuacct", "rw"], "/", "/sys/fs/cgroup/cpu acct"),
        (1, ["pids", "rw"], "/docker/abc", "/sys/fs/cgroup/pids"),
        (2, [], "/", "/sys/fs/cgroup/unified"),
    ]
    assert own_groups(CGROUP) == {"pids": "/docker/abc", "cpu": "/", "": "/user.slice/app.scope"}
    m = Mount(1, frozenset({"pids"}), "/docker/abc", Path("/x"))
    assert cgroups._inside(m, "/docker/abc/sub") == Path("/x/sub")
    assert cgroups._inside(m, "/other") is None


def test_a_v2_group_is_made_beside_this_process_s_own(tmp_path: Path) -> None:
    """cgroup v2 keeps no process in a group whose controllers are handed down: the jail's
    group is a sibling of this process's own, in the parent that hands down ``pids``."""
    root = tmp_path / "unified"
    (root / "user.slice" / "app.scope").mkdir(parents=True)
    (root / "user.slice" / "cgroup.subtree_control").write_text("cpu memory pids\n")
    info = f"41 31 0:38 / {root} rw - cgroup2 cgroup2 rw\n"
    place = find_place(info, "0::/user.slice/app.scope\n")
    assert place is not None and place.by == "cgroup v2 pids"
    assert place.pids == place.cpu == place.memory == root / "user.slice" and place.version == 2
    (root / "user.slice" / "cgroup.subtree_control").write_text("memory\n")
    assert find_place(info, "0::/user.slice/app.scope\n") is None  # no pids handed down


def test_a_v1_group_is_made_below_this_process_s_own(tmp_path: Path) -> None:
    pids, cpu, memory = tmp_path / "pids", tmp_path / "cpu", tmp_path / "memory"
    (pids / "docker").mkdir(parents=True)
    cpu.mkdir()
    (memory / "api" / "7f").mkdir(parents=True)
    info = (
        f"39 31 0:36 / {pids} rw - cgroup cgroup rw,pids\n"
        f"32 31 0:29 / {cpu} rw - cgroup cgroup rw,cpu,cpuacct\n"
        f"35 31 0:32 / {memory} rw - cgroup cgroup rw,memory\n"
    )
    place = find_place(info, "8:pids:/docker\n2:cpu,cpuacct:/\n4:memory:/api/7f\n")
    assert place is not None and place.by == "cgroup v1 pids"
    assert (place.pids, place.cpu, place.version) == (pids / "docker", cpu, 1)
    assert place.memory == memory / "api" / "7f"
    place = find_place(info, "8:pids:/docker\n2:cpu,cpuacct:/\n")
    assert place is not None and place.memory is None  # not in a memory group: no bound
    assert find_place(info.splitlines()[1], "2:cpu,cpuacct:/\n") is None  # no pids: none


def test_groups_left_by_a_dead_grader_are_swept(tmp_path: Path) -> None:
    dead = subprocess.Popen(["true"])
    dead.wait()
    (tmp_path / f"{cgroups.PREFIX}{dead.pid}-0").mkdir()
    (tmp_path / f"{cgroups.PREFIX}{dead.pid}-probe").mkdir()  # died while it looked
    (tmp_path / f"{cgroups.PREFIX}{os.getpid()}-0").mkdir()
    (tmp_path / "someone-else").mkdir()
    cgroups.sweep(tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        f"{cgroups.PREFIX}{os.getpid()}-0",
        "someone-else",
    ]


def _in_group(group: cgroups.Group, code: str) -> subprocess.CompletedProcess[bytes]:
    """Run Python ``code`` in ``group`` (joined from its first process, as the jail joins)."""
    procs = " ".join(f'"{p}"' for p in group.procs)
    shell = f'for f in {procs}; do echo $$ > $f; done; exec python3 -c "$0"'
    return subprocess.run(["/bin/sh", "-c", shell, code], capture_output=True, timeout=60)


@contextlib.contextmanager
def _real_group(limiter: Limiter) -> Iterator[cgroups.Group]:
    """A group of ``limiter``'s, emptied and removed at the end."""
    group = limiter.group()
    assert group is not None
    try:
        yield group
    finally:
        for pid in group.pids():
            os.kill(pid, 9)
        assert group.empty(10.0)
        group.remove()
    assert group.folders == []


def test_a_real_group_bounds_a_fork_loop() -> None:
    limiter = Limiter(8, 1.0)
    if limiter.by is None:
        pytest.skip("no control group can be made here")
    loop = (
        "import os, time\nn = 0\ntry:\n    while n < 100:\n        if os.fork() == 0:\n"
        "            os.closerange(0, 3)\n            time.sleep(30)\n            os._exit(0)\n"
        "        n += 1\nexcept OSError:\n    pass\nprint(n)\n"
    )
    with _real_group(limiter) as group:
        assert int(_in_group(group, loop).stdout) == 7  # 8 with the loop itself
        assert group.refused_forks() >= 1
        assert group.peak() in (None, 8)


def test_a_real_group_weighs_next_to_nothing_between_calls() -> None:
    """A noisy student's processes spinning between its calls take only CPU nobody else wants
    (REDTEAM-4 finding 13); asked, it weighs as any process, held to one core."""
    limiter = Limiter(8, 1.0)
    if not limiter.cpu:
        pytest.skip("no cpu control group can be made here")
    with _real_group(limiter) as group:
        assert group.cpu is not None
        v2 = (group.cpu / "cpu.weight").exists()
        weight = group.cpu / ("cpu.weight" if v2 else "cpu.shares")
        group.weigh(False)
        assert weight.read_text().split() == ["1" if v2 else "2"]
        group.weigh(True)
        assert weight.read_text().split() == ["100" if v2 else "1024"]
        quota = (group.cpu / ("cpu.max" if v2 else "cpu.cfs_quota_us")).read_text().split()
        assert quota[0] == "100000"


def test_a_real_group_bounds_the_memory_of_its_processes_in_all() -> None:
    """Three processes of 40 MB each are under any one process's limit, but not under the
    group's 96 MB: the kernel kills one of them (SIGKILL), and the group says so."""
    limiter = Limiter(8, None, 96)
    if not limiter.memory:
        pytest.skip("no memory control group can be made here")
    with _real_group(limiter) as group:
        assert group.memory is not None
        out = _in_group(group, hog(3, 40, 2, within_s=10.0) + "print(killed)\n")
        assert out.stdout.strip() == b"1", out.stderr
        assert group.out_of_memory() >= 1
        peak = group.memory_peak()
        assert peak is not None and 80 << 20 < peak <= 96 << 20
