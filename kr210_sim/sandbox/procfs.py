"""What the kernel says of a jail's processes, read from ``/proc`` outside the jail.

A jail's processes are seen here by their pids in the grader's PID namespace; nothing read here
was written by the user's code: the kernel keeps these figures (:meth:`~kr210_sim.sandbox.jail.
Jail.end` reads them before it kills the jail).
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path


def descendants(root: int) -> list[int]:
    """The live processes below ``root`` (from ``/proc``: pids as this process sees them;
    zombies, which have ended, left out)."""
    children: dict[int, list[int]] = {}
    for entry in os.scandir("/proc"):
        if not entry.name.isdigit():
            continue
        try:
            fields = Path(f"/proc/{entry.name}/stat").read_text().rsplit(")", 1)[1].split()
            state, ppid = fields[0], int(fields[1])
        except (OSError, ValueError, IndexError):
            continue
        if state != "Z":
            children.setdefault(ppid, []).append(int(entry.name))
    out, todo = [], list(children.get(root, ()))
    while todo:
        pid = todo.pop()
        out.append(pid)
        todo.extend(children.get(pid, ()))
    return out


def net_counters(pid: int) -> dict[str, int]:
    """The network namespace's counters of process ``pid`` that say it tried to reach out:
    ``tcp`` connections opened (``Tcp: ActiveOpens``) and ``udp`` datagrams sent (IPv4 and
    IPv6), from ``/proc/PID/net/snmp`` and ``snmp6`` (the kernel's, for that namespace)."""
    out = {"tcp": 0, "udp": 0}
    try:
        lines = Path(f"/proc/{pid}/net/snmp").read_text().splitlines()
    except OSError:
        return out
    for names, values in zip(lines[::2], lines[1::2], strict=False):
        kind, _, keys = names.partition(":")
        table = dict(zip(keys.split(), values.partition(":")[2].split(), strict=False))
        with contextlib.suppress(ValueError):
            if kind == "Tcp":
                out["tcp"] += int(table.get("ActiveOpens", 0))
            elif kind == "Udp":
                out["udp"] += int(table.get("OutDatagrams", 0))
    with contextlib.suppress(OSError, ValueError):
        for line in Path(f"/proc/{pid}/net/snmp6").read_text().splitlines():
            key, _, value = line.partition(" ")
            if key == "Udp6OutDatagrams":
                out["udp"] += int(value.strip())
    return out


def cpu_seconds(pids: list[int]) -> float:
    """CPU time of processes ``pids`` and of the children each has reaped [s] (``/proc/PID/stat``:
    utime, stime, cutime, cstime). A jail's processes die with its init and nobody reaps them
    into this process's ``RUSAGE_CHILDREN``, so the jail's end reads them here first."""
    tick = os.sysconf("SC_CLK_TCK")
    total = 0
    for pid in pids:
        with contextlib.suppress(OSError, ValueError, IndexError):
            fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
            total += sum(int(v) for v in fields[11:15])
    return total / tick


def inner_pid(pid: int) -> int | None:
    """Process ``pid``'s pid in its own PID namespace (the last of its ``NSpid``)."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("NSpid:"):
                return int(line.split()[-1])
    except (OSError, ValueError, IndexError):
        pass
    return None


def task_times(pids: list[int]) -> dict[int, tuple[int, int]]:
    """Each live task (thread) of processes ``pids``: its CPU time and the time it spent
    runnable but waiting for a CPU (the run-queue wait), both since it started [ns], by thread
    id (``/proc/PID/task/TID/schedstat``'s first two fields; the kernel's, with
    ``CONFIG_SCHED_INFO``, which every distribution's kernel has). A task that ended is left
    out; a kernel that keeps no such figures gives zeros."""
    out: dict[int, tuple[int, int]] = {}
    for pid in pids:
        try:
            tids = os.listdir(f"/proc/{pid}/task")
        except OSError:
            continue
        for tid in tids:
            with contextlib.suppress(OSError, ValueError, IndexError):
                fields = Path(f"/proc/{pid}/task/{tid}/schedstat").read_text().split()
                out[int(tid)] = (int(fields[0]), int(fields[1]))
    return out


def process_ticks(pids: list[int]) -> dict[int, int]:
    """CPU time of each of processes ``pids`` [clock ticks]: its threads, the ended ones too, and
    the children it has reaped (``/proc/PID/stat``: utime, stime, cutime, cstime)."""
    out = {}
    for pid in pids:
        with contextlib.suppress(OSError, ValueError, IndexError):
            fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
            out[pid] = sum(int(v) for v in fields[11:15])
    return out


def runnable(pids: list[int]) -> frozenset[int]:
    """The live tasks (thread ids) of processes ``pids`` that are running or ready to run (state
    ``R`` in ``/proc/PID/task/TID/stat``)."""
    out = set()
    for pid in pids:
        try:
            tids = os.listdir(f"/proc/{pid}/task")
        except OSError:
            continue
        for tid in tids:
            with contextlib.suppress(OSError, ValueError, IndexError):
                state = (
                    Path(f"/proc/{pid}/task/{tid}/stat").read_text().rsplit(")", 1)[1].split()[0]
                )
                if state == "R":
                    out.add(int(tid))
    return frozenset(out)
