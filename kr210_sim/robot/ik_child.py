"""The user's side of :class:`~kr210_sim.robot.ik_sandbox.IkSandbox`: the process that imports the
user's IK and answers its calls.

``python -m kr210_sim.robot.ik_child SPEC REQUEST_FD ANSWER_FD PARENT_PID LIMITS_JSON`` sets its
limits (:func:`set_limits`), imports the SPEC with :func:`~kr210_sim.robot.user_ik.load_ik` (so a
bad SPEC gives the same one-line message as in process), says ``ready`` and then answers
``solve(T, q_ref)`` requests read from REQUEST_FD until that pipe closes. Each answer is one
message (:func:`reply`) carrying its request's number ``n``; texts in it are cut to
:data:`~kr210_sim.robot.ik_wire.MAX_TEXT` characters, so an exception with a 2 MB message is
still an answer.

Everything here runs beside the user's code and can be undone by it: the side that reads the
answers trusts none of them (:mod:`kr210_sim.robot.ik_wire`).
"""

from __future__ import annotations

import json
import math
import os
import sys
from typing import Any

import numpy as np
import numpy.typing as npt

from kr210_sim.errors import IkSpecError
from kr210_sim.robot.ik_wire import receive, send, short
from kr210_sim.robot.user_ik import load_ik
from kr210_sim.util.processes import die_with_parent

FloatArray = npt.NDArray[np.float64]

#: Most numbers an answer carries back: six angles, or the first of a larger array's (its shape
#: is sent whole, so the guard can say "returned shape (100, 6)").
MAX_NUMBERS = 64


def reply(fn: Any, T: FloatArray, q_ref: FloatArray) -> dict[str, Any]:
    """``fn(T, q_ref)`` as a message.

    Returns:
        ``{"q": [...], "shape": [...]}`` for numbers (no values past :data:`MAX_NUMBERS`),
        ``{"none": True}``, ``{"raised": type name, "message": text}``, ``{"object": type name,
        "why": text}`` for an answer that is not numbers, ``{"memory": True}`` when it ran out
        of memory, ``{"exit": code}`` when it called ``sys.exit``.
    """
    try:
        out = fn(T, q_ref)
    except MemoryError:
        return {"memory": True}
    except SystemExit as exc:
        return {"exit": exc.code if isinstance(exc.code, int | None) else short(str(exc.code))}
    except BaseException as exc:  # every fault of the user's code is an answer
        return {"raised": short(type(exc).__name__, 200), "message": short(str(exc))}
    if out is None:
        return {"none": True}
    try:
        arr = np.asarray(out, dtype=np.float64)
    except MemoryError:
        return {"memory": True}
    except Exception as exc:
        return {"object": short(type(out).__name__, 200), "why": short(str(exc))}
    if arr.size > MAX_NUMBERS:
        return {"q": [], "shape": list(arr.shape[:1]) + [0] * (arr.ndim - 1)}
    return {"q": arr.reshape(-1).tolist(), "shape": list(arr.shape)}


#: CPU time past ``cpu_s`` before SIGKILL follows SIGXCPU [s].
CPU_GRACE = 1


def _cap(kind: int, value: int) -> None:
    """Set limit ``kind`` (soft and hard) to ``value``, or to the hard limit when that is lower
    (a process may only lower its hard limits)."""
    import resource

    hard = resource.getrlimit(kind)[1]
    if hard != resource.RLIM_INFINITY:
        value = min(value, hard)
    resource.setrlimit(kind, (value, value))


def set_limits(limits: dict[str, Any], parent: int) -> None:
    """Die with ``parent``; no core dumps; files of at most ``file_mb``; and when given:
    ``memory_mb`` of address space, ``cpu_s`` seconds of CPU time (SIGXCPU, then SIGKILL
    :data:`CPU_GRACE` s later), ``open_files`` file descriptors, ``processes`` processes of
    this user (``RLIMIT_NPROC``: in a user namespace of its own, those of the jail). Soft
    limits are set to the hard ones, so the user's code cannot raise them."""
    import resource

    die_with_parent(parent)
    _cap(resource.RLIMIT_CORE, 0)
    _cap(resource.RLIMIT_FSIZE, int(limits["file_mb"]) << 20)
    if limits.get("memory_mb"):
        _cap(resource.RLIMIT_AS, int(limits["memory_mb"]) << 20)
    if limits.get("cpu_s"):
        seconds = max(1, math.ceil(float(limits["cpu_s"])))
        hard = resource.getrlimit(resource.RLIMIT_CPU)[1]
        top = seconds + CPU_GRACE if hard == resource.RLIM_INFINITY else min(hard, seconds)
        resource.setrlimit(resource.RLIMIT_CPU, (min(seconds, top), top))
    if limits.get("open_files"):
        _cap(resource.RLIMIT_NOFILE, int(limits["open_files"]))
    if limits.get("processes"):
        _cap(resource.RLIMIT_NPROC, int(limits["processes"]))


def _load_failure(exc: IkSpecError) -> dict[str, Any]:
    """The message for a SPEC that did not load: its one line, or what the import ran into."""
    cause = exc.__context__
    if isinstance(cause, MemoryError):
        return {"memory": True}
    if isinstance(cause, SystemExit):
        return {"exit": cause.code if isinstance(cause.code, int | None) else 1}
    return {"error": short(str(exc))}


def serve(argv: list[str]) -> int:
    """The user's process: set the limits, import the SPEC, answer calls until the pipe closes.

    Args:
        argv: ``SPEC REQUEST_FD ANSWER_FD PARENT_PID LIMITS_JSON`` (PARENT_PID 0: do not check
            the parent's pid, only die with it).
    """
    spec, req, ans, parent, limits = argv[0], int(argv[1]), int(argv[2]), int(argv[3]), argv[4]
    set_limits(json.loads(limits), parent)
    try:
        fn = load_ik(spec).function
    except MemoryError:
        send(ans, {"memory": True})
        return 1
    except IkSpecError as exc:
        send(ans, _load_failure(exc))
        return 1
    send(ans, {"ready": True})
    while True:
        message = receive(req, None)
        if not isinstance(message, dict):
            return 0
        T = np.asarray(message["T"], dtype=np.float64).reshape(4, 4)
        q_ref = np.asarray(message["q"], dtype=np.float64)
        answer = reply(fn, T, q_ref)
        send(ans, {"n": message.get("n"), **answer})
        if "exit" in answer or "memory" in answer:
            code = answer.get("exit")
            os._exit(code if isinstance(code, int) else 1)


if __name__ == "__main__":
    sys.exit(serve(sys.argv[1:]))
