"""Control groups for a jail: bounds on its processes, CPU and memory that the kernel keeps.

A :class:`Limiter` looks once for a place where this process may make control groups: cgroup v2
with the ``pids`` controller (a sibling of this process's own group, as a desktop's systemd
delegates them), else the cgroup v1 ``pids`` hierarchy (a child of this process's group, as in a
container run as root). Each jailed process tree gets a :class:`Group` of its own there:
``pids.max`` processes at most (a fork past it fails with ``EAGAIN``), one core's worth of
CPU, weighed as little as the kernel allows between its calls (:meth:`Group.weigh`), where the
``cpu`` controller is at hand too, and a bound on the memory of all its processes
and the files of its tmpfs together where the ``memory`` controller is (past it the kernel
reclaims, then kills the group's largest process; no swap). The group is read from outside the
jail at the end (forks refused, the most processes at once, CPU throttling, memory peak and
processes killed out of memory) and removed.

Where there is no such place, :attr:`Limiter.by` says so and the jail falls back on
``RLIMIT_NPROC``, set inside (it counts per user in the jail's own user namespace, but the kernel
ignores it for root).
"""

from __future__ import annotations

import contextlib
import itertools
import os
import re
import time
from dataclasses import dataclass
from pathlib import Path

#: Names of the groups made here: ``kr210-jail-PID-N`` (PID: the process that made it).
PREFIX = "kr210-jail-"
#: CPU period of the one-core quota [µs].
CPU_PERIOD_US = 100_000
#: A jail's CPU weight while the grader waits for no answer of it (:meth:`Group.weigh`), as
#: (cgroup v2 ``cpu.weight``, v1 ``cpu.shares``): the least the kernel takes, against 100 and
#: 1024 for a process outside any group of ours. Between its calls a student's processes get only
#: CPU that nobody else wants, so threads spinning on every core, or a flood of output, take
#: nothing from a neighbour; while it is asked, it weighs as any process (a lower weight then
#: would turn a loaded machine into its timeouts).
IDLE_WEIGHT = (1, 2)
#: The weight while it is asked (the kernel's default).
BUSY_WEIGHT = (100, 1024)


@dataclass(frozen=True, slots=True)
class Mount:
    """A mounted cgroup hierarchy.

    Attributes:
        version: 1 or 2.
        options: The v1 controllers it carries (``{"pids"}``, ``{"cpu", "cpuacct"}``); empty
            for v2.
        root: The hierarchy's path that is mounted (``/`` unless a container shows a part).
        point: Where it is mounted.
    """

    version: int
    options: frozenset[str]
    root: str
    point: Path


def mounts(mountinfo: str) -> list[Mount]:
    """The cgroup hierarchies in ``/proc/self/mountinfo``'s text."""
    found = []
    for line in mountinfo.splitlines():
        left, sep, right = line.partition(" - ")
        if not sep:
            continue
        fields, tail = left.split(), right.split()
        if len(fields) < 5 or len(tail) < 3:
            continue
        point = Path(fields[4].replace("\\040", " "))
        if tail[0] == "cgroup2":
            found.append(Mount(2, frozenset(), fields[3], point))
        elif tail[0] == "cgroup":
            found.append(Mount(1, frozenset(tail[2].split(",")), fields[3], point))
    return found


def own_groups(cgroup: str) -> dict[str, str]:
    """This process's group per hierarchy from ``/proc/self/cgroup``'s text: ``{"": v2 path,
    "pids": v1 path, "cpu,cpuacct": ...}`` (v1 keys are the line's controller list)."""
    out = {}
    for line in cgroup.splitlines():
        parts = line.split(":", 2)
        if len(parts) == 3:
            out[parts[1]] = parts[2]
    return out


def _inside(mount: Mount, path: str) -> Path | None:
    """Where group ``path`` of ``mount``'s hierarchy is on disk (None: not under its root)."""
    root = mount.root.rstrip("/")
    if root and not (path == root or path.startswith(root + "/")):
        return None
    return mount.point / path[len(root) :].lstrip("/")


def _writable(folder: Path) -> bool:
    """Whether a group can be made in ``folder`` (made and removed to find out)."""
    probe = folder / f"{PREFIX}{os.getpid()}-probe"
    try:
        probe.mkdir()
    except OSError:
        return False
    with contextlib.suppress(OSError):
        probe.rmdir()
    return True


def _controllers(folder: Path) -> set[str]:
    try:
        return set((folder / "cgroup.subtree_control").read_text().split())
    except OSError:
        return set()


@dataclass(frozen=True, slots=True)
class Place:
    """Where a jail's groups are made: one folder per hierarchy the group joins.

    Attributes:
        by: What bounds the processes (``cgroup v2 pids``, ``cgroup v1 pids``).
        pids: The folder the ``pids`` group is made in.
        cpu: The folder the ``cpu`` group is made in (v1: another hierarchy; v2: ``pids``'s),
            or None: no CPU quota.
        version: 1 or 2.
        memory: The folder the ``memory`` group is made in, or None: no bound on the memory of
            the group in all.
    """

    by: str
    pids: Path
    cpu: Path | None
    version: int
    memory: Path | None = None


def find_place(mountinfo: str, cgroup: str) -> Place | None:
    """Where this process may make groups with a ``pids`` controller (see the module doc), from
    the texts of ``/proc/self/mountinfo`` and ``/proc/self/cgroup``; None: nowhere."""
    hierarchies = mounts(mountinfo)
    own = own_groups(cgroup)
    for m in hierarchies:
        if m.version != 2 or "" not in own:
            continue
        here = _inside(m, own[""])
        if here is None:
            continue
        parent = here if here == m.point else here.parent  # v2: no process in a parent group
        have = _controllers(parent)
        if "pids" in have and _writable(parent):
            cpu = parent if "cpu" in have else None
            return Place("cgroup v2 pids", parent, cpu, 2, parent if "memory" in have else None)
    v1: dict[str, Path] = {}
    for m in hierarchies:
        if m.version != 1:
            continue
        path = next((p for k, p in own.items() if k and set(k.split(",")) <= m.options), None)
        here = None if path is None else _inside(m, path)
        if here is None:
            continue
        for name in ("pids", "cpu", "memory"):
            if name in m.options and name not in v1 and _writable(here):
                v1[name] = here
    if "pids" in v1:
        return Place("cgroup v1 pids", v1["pids"], v1.get("cpu"), 1, v1.get("memory"))
    return None


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def sweep(folder: Path) -> None:
    """Remove the empty groups that processes now gone left in ``folder`` (a grader killed
    before it could remove them)."""
    with contextlib.suppress(OSError):
        for entry in folder.iterdir():
            m = re.fullmatch(re.escape(PREFIX) + r"(\d+)-(\d+|probe)", entry.name)
            if m and not _alive(int(m.group(1))):
                with contextlib.suppress(OSError):
                    entry.rmdir()


_COUNTER = itertools.count()


class Group:
    """One jailed process tree's control groups (made by :meth:`Limiter.group`).

    Args:
        place: Where to make them.
        processes: ``pids.max``.
        cores: CPU quota in cores (with a ``cpu`` place), or None for none.
        memory_mb: Memory of the group in all (with a ``memory`` place) [MB], or None for no
            bound.
    """

    def __init__(
        self, place: Place, processes: int, cores: float | None, memory_mb: int | None = None
    ) -> None:
        self.place = place
        name = f"{PREFIX}{os.getpid()}-{next(_COUNTER)}"
        self.folders: list[Path] = []
        try:
            pids = place.pids / name
            pids.mkdir()
            self.folders.append(pids)
            (pids / "pids.max").write_text(f"{processes}\n")
            self.cpu: Path | None = None
            if place.cpu is not None and cores is not None:
                cpu = place.cpu / name
                if cpu != pids:
                    cpu.mkdir()
                    self.folders.append(cpu)
                quota = int(cores * CPU_PERIOD_US)
                if place.version == 2:
                    (cpu / "cpu.max").write_text(f"{quota} {CPU_PERIOD_US}\n")
                else:
                    (cpu / "cpu.cfs_period_us").write_text(f"{CPU_PERIOD_US}\n")
                    (cpu / "cpu.cfs_quota_us").write_text(f"{quota}\n")
                self.cpu = cpu
            self.memory: Path | None = None
            if place.memory is not None and memory_mb is not None:
                self.memory = self._bound_memory(place.memory / name, memory_mb << 20)
        except OSError:
            self.remove()
            raise

    def _bound_memory(self, folder: Path, limit: int) -> Path:
        """Make ``folder`` a group of at most ``limit`` bytes and no swap."""
        if folder not in self.folders:
            folder.mkdir()
            self.folders.append(folder)
        if self.place.version == 2:
            (folder / "memory.max").write_text(f"{limit}\n")
            with contextlib.suppress(OSError):  # (no swap accounting: nothing to bound)
                (folder / "memory.swap.max").write_text("0\n")
        else:
            (folder / "memory.limit_in_bytes").write_text(f"{limit}\n")
            with contextlib.suppress(OSError):  # memory and swap: as much, so no swap
                (folder / "memory.memsw.limit_in_bytes").write_text(f"{limit}\n")
        return folder

    def weigh(self, busy: bool) -> None:
        """Weigh the group as any process while the grader waits for its answer (``busy``),
        else as little as the kernel allows (:data:`IDLE_WEIGHT`): nothing where there is no
        ``cpu`` group, or the kernel refuses."""
        if self.cpu is None:
            return
        v2, v1 = BUSY_WEIGHT if busy else IDLE_WEIGHT
        name, value = ("cpu.weight", v2) if self.place.version == 2 else ("cpu.shares", v1)
        with contextlib.suppress(OSError):
            (self.cpu / name).write_text(f"{value}\n")

    @property
    def procs(self) -> list[Path]:
        """The ``cgroup.procs`` files a process joins all the groups by (its pid written)."""
        return [f / "cgroup.procs" for f in self.folders]

    def pids(self) -> list[int]:
        """The processes in the group now (pids as this process sees them)."""
        try:
            return [int(p) for p in (self.folders[0] / "cgroup.procs").read_text().split()]
        except (OSError, ValueError, IndexError):
            return []

    def _read(self, folder: Path | None, name: str) -> dict[str, int]:
        if folder is None:
            return {}
        try:
            lines = (folder / name).read_text().splitlines()
        except OSError:
            return {}
        out = {}
        for line in lines:
            key, _, value = line.partition(" ")
            with contextlib.suppress(ValueError):
                out[key] = int(value)
        return out

    def refused_forks(self) -> int:
        """Forks refused at ``pids.max`` so far (``pids.events``' ``max``)."""
        return self._read(self.folders[0] if self.folders else None, "pids.events").get("max", 0)

    def peak(self) -> int | None:
        """The most processes the group held at once (``pids.peak``; None where the kernel has
        no such file)."""
        if not self.folders:
            return None
        try:
            return int((self.folders[0] / "pids.peak").read_text())
        except (OSError, ValueError):
            return None

    def throttled(self) -> tuple[int, float]:
        """How often the CPU quota held the group back and for how long [s]."""
        stat = self._read(self.cpu, "cpu.stat")
        if "throttled_usec" in stat:
            return stat.get("nr_throttled", 0), stat["throttled_usec"] / 1e6
        return stat.get("nr_throttled", 0), stat.get("throttled_time", 0) / 1e9

    def usage(self) -> int | None:
        """CPU time of the group's processes in all, the ended ones too [ns] (v2 ``cpu.stat``'s
        ``usage_usec``, v1 ``cpuacct.usage`` where ``cpuacct`` is mounted with ``cpu``; None
        where there is no such figure)."""
        if self.place.version == 2:
            stat = self._read(self.folders[0] if self.folders else None, "cpu.stat")
            return stat["usage_usec"] * 1000 if "usage_usec" in stat else None
        if self.cpu is None:
            return None
        try:
            return int((self.cpu / "cpuacct.usage").read_text())
        except (OSError, ValueError):
            return None

    def memory_peak(self) -> int | None:
        """The most memory the group held at once [bytes] (None: no memory group, or a kernel
        with no such file)."""
        name = "memory.peak" if self.place.version == 2 else "memory.max_usage_in_bytes"
        if self.memory is None:
            return None
        try:
            return int((self.memory / name).read_text())
        except (OSError, ValueError):
            return None

    def out_of_memory(self) -> int:
        """Processes the kernel killed because the group reached its memory bound (v2
        ``memory.events``' ``oom_kill``, v1 ``memory.oom_control``'s)."""
        name = "memory.events" if self.place.version == 2 else "memory.oom_control"
        return self._read(self.memory, name).get("oom_kill", 0)

    def empty(self, within: float) -> bool:
        """Wait up to ``within`` s for the group to hold no process; whether it does."""
        end = time.monotonic() + within
        while self.pids():
            if time.monotonic() > end:
                return False
            time.sleep(0.005)
        return True

    def remove(self) -> None:
        """Remove the groups (each must be empty; one that is not stays)."""
        for folder in reversed(self.folders):
            with contextlib.suppress(OSError):
                folder.rmdir()
        self.folders = [f for f in self.folders if f.exists()]


class Limiter:
    """Finds once where groups can be made (:func:`find_place`) and makes them.

    Args:
        processes: ``pids.max`` of each group.
        cores: CPU quota of each group in cores (None: none).
        memory_mb: Memory of each group in all [MB] (None: no bound).
    """

    def __init__(self, processes: int, cores: float | None, memory_mb: int | None = None) -> None:
        self.processes = processes
        self.cores = cores
        self.memory_mb = memory_mb
        try:
            mountinfo = Path("/proc/self/mountinfo").read_text()
            cgroup = Path("/proc/self/cgroup").read_text()
        except OSError:
            mountinfo = cgroup = ""
        self.place = find_place(mountinfo, cgroup)
        if self.place is not None:
            for folder in {self.place.pids, self.place.cpu, self.place.memory}:
                if folder is not None:
                    sweep(folder)

    @property
    def by(self) -> str | None:
        """``cgroup v2 pids``, ``cgroup v1 pids``, or None: no group can be made here."""
        return None if self.place is None else self.place.by

    @property
    def cpu(self) -> bool:
        """Whether each group holds its processes to :attr:`cores` of CPU."""
        return self.place is not None and self.place.cpu is not None and self.cores is not None

    @property
    def memory(self) -> bool:
        """Whether each group bounds the memory of its processes in all to :attr:`memory_mb`."""
        return self.place is not None and self.place.memory is not None and bool(self.memory_mb)

    def group(self) -> Group | None:
        """A new group, or None where none can be made (any more)."""
        if self.place is None:
            return None
        try:
            return Group(self.place, self.processes, self.cores, self.memory_mb)
        except OSError:
            return None
