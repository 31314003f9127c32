"""The jail's seccomp filter (sandbox/seccomp.py): the numbers are the kernel's, the program is
well formed, and in a jail the refused calls fail with EPERM while Python works as before."""

from __future__ import annotations

import json
import re
import struct
import textwrap
from pathlib import Path

import numpy as np
import pytest

from kr210_sim.robot import kinematics
from kr210_sim.sandbox import seccomp
from kr210_sim.sandbox.ik_sandbox import IkSandbox
from kr210_sim.sandbox.jail import Jail

HEADERS = {
    "x86_64": Path("/usr/include/x86_64-linux-gnu/asm/unistd_64.h"),
    "aarch64": Path("/usr/include/asm-generic/unistd.h"),
}


@pytest.mark.parametrize("arch", ["x86_64", "aarch64"])
def test_the_numbers_are_the_kernels(arch: str) -> None:
    header = HEADERS[arch]
    if not header.is_file():
        pytest.skip(f"no {header} (linux-libc-dev)")
    text = header.read_text()
    kernel = {name: int(nr) for name, nr in re.findall(r"#define __NR_(\w+)\s+(\d+)\b", text)}
    column = 0 if arch == "x86_64" else 1
    for name, pair in seccomp.DENIED.items():
        want = pair[column]
        if want is None:
            assert name not in kernel, f"{arch} has {name} after all"
        else:
            assert kernel.get(name) == want, (
                f"{arch} {name}: ours {want}, kernel {kernel.get(name)}"
            )


def _run_filter(code: bytes, arch: int, nr: int, arg0: int = 0) -> int:
    """What the classic-BPF ``code`` returns for one call: a small interpreter of the four
    instructions the filter uses (load word, jump if equal, jump if at least, return)."""
    data = struct.pack("=iIQ6Q", nr, arch, 0, arg0 & 0xFFFFFFFF, 0, 0, 0, 0, 0)
    ops = [struct.unpack("=HBBI", code[i : i + 8]) for i in range(0, len(code), 8)]
    pc, acc = 0, 0
    for _ in range(len(ops)):
        op, jt, jf, k = ops[pc]
        if op == 0x20:
            acc = struct.unpack_from("=I", data, k)[0]
        elif op in (0x15, 0x35):
            taken = acc == k if op == 0x15 else acc >= k
            pc += jt if taken else jf
        elif op == 0x06:
            return k
        else:
            raise AssertionError(f"unknown instruction {op:#x}")
        pc += 1
    raise AssertionError("ran off the end of the program")


@pytest.mark.parametrize("arch", ["x86_64", "aarch64"])
def test_the_program_refuses_each_denied_call_and_foreign_socket_families(arch: str) -> None:
    """Every call and family run through the filter by an interpreter: the denied calls, another
    ABI and x32 get EPERM; socket and socketpair of a family other than Unix, IPv4 and IPv6
    (netlink 16, packet 17, crypto 38, vsock 40: red team 4, finding 14) get EAFNOSUPPORT;
    everything else, and those three families, are allowed."""
    code = seccomp.program(arch)
    audit = seccomp.AUDIT_ARCH[arch]
    allow, eperm, eafnosupport = 0x7FFF0000, 0x00050000 | 1, 0x00050000 | 97
    denied = set(seccomp.numbers(arch))
    column = 0 if arch == "x86_64" else 1
    sockets = {pair[column] for pair in seccomp.SOCKET_CALLS.values()}
    for nr in range(0, 460):
        want = eperm if nr in denied else allow
        if nr in sockets:
            for family in (1, 2, 10):
                assert _run_filter(code, audit, nr, family) == allow, (nr, family)
            for family in (0, 16, 17, 38, 40, 44, 0x10000 + 1):
                assert _run_filter(code, audit, nr, family) == eafnosupport, (nr, family)
        else:
            assert _run_filter(code, audit, nr, 16) == want, nr
    assert _run_filter(code, 0x40000003, 41, 1) == eperm  # i386 calls on x86_64: refused
    if arch == "x86_64":
        assert _run_filter(code, audit, seccomp.X32_SYSCALL_BIT + 41, 1) == eperm  # x32
    with pytest.raises(ValueError):
        seccomp.program("riscv64")


def test_in_the_jail_the_refused_calls_fail_and_python_works(tmp_path: Path, jail_ok: None) -> None:
    arch = seccomp.machine()
    if arch is None:
        pytest.skip("no seccomp filter for this machine")
    calls = {name: pair[0 if arch == "x86_64" else 1] for name, pair in seccomp.DENIED.items()}
    user = tmp_path / "sys.py"
    user.write_text(
        textwrap.dedent(
            f"""
            import ctypes, json, os, subprocess, sys, threading
            libc = ctypes.CDLL(None, use_errno=True)
            found = {{}}
            for name in ("ptrace", "keyctl", "bpf", "unshare", "mount", "io_uring_setup",
                         "perf_event_open", "userfaultfd", "setns", "personality"):
                nr = {calls!r}[name]
                ctypes.set_errno(0)
                found[name] = (libc.syscall(nr, 0, 0, 0, 0, 0), ctypes.get_errno())
            import socket
            for name, family in (("netlink", 16), ("vsock", 40), ("packet", 17)):
                try:
                    socket.socket(family, socket.SOCK_DGRAM).close()
                    found[name] = "opened"
                except OSError as exc:
                    found[name] = exc.errno
            a, b = socket.socketpair()
            a.sendall(b"ok")
            found["unix"] = b.recv(2).decode()
            t = threading.Thread(target=lambda: None)
            t.start()
            t.join()
            pid = os.fork()
            if pid == 0:
                os._exit(7)
            found["fork"] = os.waitpid(pid, 0)[1] >> 8
            found["subprocess"] = subprocess.run([sys.executable, "-c", "print(6 * 7)"],
                                                 capture_output=True, text=True).stdout.strip()
            print("FOUND " + json.dumps(found), flush=True)
            def solve(T, q_ref):  # the grader's solver is not in the jail: q_ref back
                return q_ref
            """
        )
    )
    with IkSandbox(f"{user}:solve", capture=True, confinement=Jail(), root=user) as box:
        q = np.array([0.3, 0.2, -0.3, 0.5, 0.6, -0.4])
        np.testing.assert_allclose(box(kinematics.forward(q), q), q, atol=1e-9)
    line = next(ln for ln in box.stdout.text().splitlines() if ln.startswith("FOUND "))
    found = json.loads(line[6:])
    for name in ("ptrace", "keyctl", "bpf", "unshare", "mount", "io_uring_setup"):
        assert found[name] == [-1, 1], name  # EPERM
    for name in ("perf_event_open", "userfaultfd", "setns", "personality"):
        assert found[name] == [-1, 1], name
    assert found["fork"] == 7 and found["subprocess"] == "42"
    assert (found["netlink"], found["vsock"], found["packet"]) == (97, 97, 97)  # EAFNOSUPPORT
    assert found["unix"] == "ok"
