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


@pytest.mark.parametrize("arch", ["x86_64", "aarch64"])
def test_the_program_checks_the_abi_then_each_call(arch: str) -> None:
    code = seccomp.program(arch)
    ops = [struct.unpack("=HBBI", code[i : i + 8]) for i in range(0, len(code), 8)]
    n = len(seccomp.numbers(arch))
    assert len(ops) == n + (6 if arch == "x86_64" else 5)
    assert ops[0] == (0x20, 0, 0, 4) and ops[1][3] == seccomp.AUDIT_ARCH[arch]
    deny = len(ops) - 1
    assert ops[deny] == (0x06, 0, 0, 0x00050000 | 1)  # EPERM
    assert ops[deny - 1] == (0x06, 0, 0, 0x7FFF0000)  # allow
    for pc, (op, jt, jf, _k) in enumerate(ops[:-2]):
        if op in (0x15, 0x35):  # each check jumps to the refusal (or on, to the next)
            assert pc + 1 + (jt or jf) == deny or (jt == 0 and jf == 0), pc
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
            from kr210_sim.robot.kinematics import nearest as solve
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
