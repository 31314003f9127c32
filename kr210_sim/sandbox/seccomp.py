"""A seccomp filter for the jail: the system calls an IK never makes, and that kernel exploits
and escapes go through, fail with ``EPERM``.

:func:`program` builds the classic-BPF program bubblewrap loads with ``--seccomp FD``
(:class:`~kr210_sim.sandbox.jail.Jail` passes it): the calling convention must be this machine's
(any other, such as 32-bit calls on x86_64 or its x32 ABI, is refused whole), and the calls of
:data:`DENIED` are refused. What is refused: tracing and reading other processes' memory; the
kernel's keyrings; eBPF, perf events, userfaultfd and io_uring (much of the kernel's attack
surface of recent years); mounting, namespaces and file handles; kernel modules, kexec,
reboot and swap; the clock, the host name and the kernel's log; and a few old calls no program
of today makes. Everything else is allowed: Python, NumPy, threads, ``fork`` and files work as
without it.

The numbers are those of the kernel's ``asm/unistd_64.h`` (x86_64) and
``asm-generic/unistd.h`` (aarch64); ``tests/sandbox/test_seccomp.py`` reads them back from the
headers where they are installed.
"""

from __future__ import annotations

import errno
import platform
import struct

#: ``AUDIT_ARCH_*`` of each machine this filter knows.
AUDIT_ARCH = {"x86_64": 0xC000003E, "aarch64": 0xC00000B7}
#: Calls at or above this number on x86_64 are the x32 ABI's.
X32_SYSCALL_BIT = 0x40000000
_RET_ALLOW = 0x7FFF0000
_RET_ERRNO = 0x00050000
_LD_W_ABS = 0x20  # BPF_LD | BPF_W | BPF_ABS
_JEQ_K = 0x15  # BPF_JMP | BPF_JEQ | BPF_K
_JGE_K = 0x35  # BPF_JMP | BPF_JGE | BPF_K
_RET_K = 0x06  # BPF_RET | BPF_K
_NR, _ARCH = 0, 4  # offsets in struct seccomp_data

#: The refused calls and their numbers per machine (x86_64, aarch64; None: it has no such call).
DENIED: dict[str, tuple[int | None, int | None]] = {
    "ptrace": (101, 117),
    "process_vm_readv": (310, 270),
    "process_vm_writev": (311, 271),
    "kcmp": (312, 272),
    "keyctl": (250, 219),
    "add_key": (248, 217),
    "request_key": (249, 218),
    "bpf": (321, 280),
    "perf_event_open": (298, 241),
    "userfaultfd": (323, 282),
    "io_uring_setup": (425, 425),
    "io_uring_enter": (426, 426),
    "io_uring_register": (427, 427),
    "mount": (165, 40),
    "umount2": (166, 39),
    "pivot_root": (155, 41),
    "open_tree": (428, 428),
    "move_mount": (429, 429),
    "fsopen": (430, 430),
    "fsconfig": (431, 431),
    "fsmount": (432, 432),
    "fspick": (433, 433),
    "mount_setattr": (442, 442),
    "unshare": (272, 97),
    "setns": (308, 268),
    "open_by_handle_at": (304, 265),
    "name_to_handle_at": (303, 264),
    "init_module": (175, 105),
    "finit_module": (313, 273),
    "delete_module": (176, 106),
    "kexec_load": (246, 104),
    "kexec_file_load": (320, 294),
    "reboot": (169, 142),
    "swapon": (167, 224),
    "swapoff": (168, 225),
    "acct": (163, 89),
    "quotactl": (179, 60),
    "syslog": (103, 116),
    "settimeofday": (164, 170),
    "clock_settime": (227, 112),
    "clock_adjtime": (305, 266),
    "adjtimex": (159, 171),
    "sethostname": (170, 161),
    "setdomainname": (171, 162),
    "vhangup": (153, 58),
    "personality": (135, 92),
    "lookup_dcookie": (212, 18),
    "uselib": (134, None),
    "modify_ldt": (154, None),
    "iopl": (172, None),
    "ioperm": (173, None),
    "ustat": (136, None),
    "sysfs": (139, None),
}


def machine() -> str | None:
    """This machine's name in :data:`AUDIT_ARCH` (None: one the filter does not know)."""
    name = platform.machine().lower()
    name = {"amd64": "x86_64", "arm64": "aarch64"}.get(name, name)
    return name if name in AUDIT_ARCH else None


def numbers(arch: str) -> list[int]:
    """The numbers of the refused calls on ``arch`` (``x86_64`` or ``aarch64``)."""
    column = 0 if arch == "x86_64" else 1
    return sorted({nr for pair in DENIED.values() if (nr := pair[column]) is not None})


def _op(code: int, k: int, jt: int = 0, jf: int = 0) -> bytes:
    return struct.pack("=HBBI", code, jt, jf, k)


def program(arch: str) -> bytes:
    """The filter for ``arch`` as bubblewrap reads it: ``struct sock_filter`` entries, packed.

    Raises:
        ValueError: An ``arch`` the filter does not know.
    """
    if arch not in AUDIT_ARCH:
        raise ValueError(f"no seccomp filter for {arch!r}")
    denied = numbers(arch)
    deny = _RET_ERRNO | errno.EPERM
    ops = [_op(_LD_W_ABS, _ARCH)]
    checks = [_op(_JEQ_K, nr) for nr in denied]  # jump targets filled in below
    head = 3 if arch == "x86_64" else 2  # load arch, check it, load nr (+ x32 check)
    ops.append(_op(_JEQ_K, AUDIT_ARCH[arch], 0, len(checks) + head))  # another ABI: refused
    ops.append(_op(_LD_W_ABS, _NR))
    if arch == "x86_64":
        ops.append(_op(_JGE_K, X32_SYSCALL_BIT, len(checks) + 1, 0))
    for i, nr in enumerate(denied):
        ops.append(_op(_JEQ_K, nr, len(checks) - i, 0))  # to the refusal after ALLOW
    ops.append(_op(_RET_K, _RET_ALLOW))
    ops.append(_op(_RET_K, deny))
    return b"".join(ops)
