"""The user's side of :class:`~kr210_sim.sandbox.ik_sandbox.IkSandbox`: the process that imports the
user's IK and answers its calls.

``python -m kr210_sim.sandbox.ik_child SPEC REQUEST_FD ANSWER_FD PARENT_PID LIMITS_JSON`` sets its
limits (:func:`set_limits`), imports the SPEC with :func:`~kr210_sim.sandbox.user_ik.load_ik` (so a
bad SPEC gives the same one-line message as in process), says ``ready`` and then answers
``solve(T, q_ref)`` requests read from REQUEST_FD until that pipe closes, one pose each or many
(a batch: :func:`reply_batch`; a ROS-form server takes them as one request). Each answer is one
message (:func:`reply`) carrying its request's number ``n``; texts in it are cut to
:data:`~kr210_sim.sandbox.ik_wire.MAX_TEXT` characters, so an exception with a 2 MB message is
still an answer.

Everything here runs beside the user's code and can be undone by it: the side that reads the
answers trusts none of them (:mod:`kr210_sim.sandbox.ik_wire`).
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
from kr210_sim.sandbox import harness
from kr210_sim.sandbox.ik_wire import receive, send, short
from kr210_sim.sandbox.user_ik import UserIk, load_ik, where_raised
from kr210_sim.util.processes import die_with_parent

FloatArray = npt.NDArray[np.float64]

#: Most numbers an answer carries back: six angles, or the first of a larger array's (its shape
#: is sent whole, so the guard can say "returned shape (100, 6)").
MAX_NUMBERS = 64
#: Most notes (what Python 2 semantics changed in a ROS-form server) one message carries.
MAX_NOTES = 20


def _fault(exc: BaseException) -> dict[str, Any]:
    """An exception of the user's code as a message (see :func:`reply`)."""
    if isinstance(exc, MemoryError):
        return {"memory": True}
    if isinstance(exc, SystemExit):
        return {"exit": exc.code if isinstance(exc.code, int | None) else short(str(exc.code))}
    where = where_raised(exc)  # " (file.py line N)", after a message cut short too
    return {"raised": short(type(exc).__name__, 200), "message": short(str(exc)) + where}


def describe(out: Any) -> dict[str, Any]:
    """An answer of the user's code as a message (see :func:`reply`)."""
    if isinstance(out, BaseException):
        return _fault(out)
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
    except BaseException as exc:  # every fault of the user's code is an answer
        return _fault(exc)
    return describe(out)


def reply_batch(user: UserIk, poses: list[FloatArray], q_refs: list[FloatArray]) -> dict[str, Any]:
    """The answers to many poses as one message: ``{"answers": [one message per pose, as
    :func:`reply`'s]}``, or the one message of a fault that ends the process (``memory``,
    ``exit``). An IK that takes batches (:attr:`~kr210_sim.sandbox.user_ik.UserIk.batch`) gets
    them in one call (a fault of that call is every pose's answer); another is called pose by
    pose with its ``q_ref``."""
    if user.batch is None:
        answers = [reply(user.function, T, q) for T, q in zip(poses, q_refs, strict=True)]
    else:
        try:
            outs: list[Any] = list(user.batch(poses))
        except BaseException as exc:
            outs = [exc] * len(poses)
        answers = [describe(o) for o in outs]
    for a in answers:
        if "exit" in a or "memory" in a:
            return a
    return {"answers": answers}


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


def _blocked(guard: harness.Guard | None) -> dict[str, Any]:
    """``{"blocked": [names]}``: the imports of the grader's own code the guard refused since
    the last message (nothing when none or no guard)."""
    new = guard.news() if guard is not None else []
    return {"blocked": [short(n, 200) for n in new]} if new else {}


def prepare(argv: list[str]) -> tuple[str, int, int, harness.Guard | None]:
    """A user's process's start (this one's and a perception function's): ``SPEC REQUEST_FD
    ANSWER_FD PARENT_PID LIMITS_JSON`` read, the limits set, and the harness's guard put in
    place when LIMITS_JSON asks. Returns the SPEC, the two pipes' fds and the guard."""
    spec, req, ans, parent, given = argv[0], int(argv[1]), int(argv[2]), int(argv[3]), argv[4]
    limits = json.loads(given)
    set_limits(limits, parent)
    guard = harness.install() if limits.get("harness") else None
    return spec, req, ans, guard


def serve(argv: list[str]) -> int:
    """The user's process: set the limits, import the SPEC, answer calls until the pipe closes.

    Args:
        argv: ``SPEC REQUEST_FD ANSWER_FD PARENT_PID LIMITS_JSON`` (PARENT_PID 0: do not check
            the parent's pid, only die with it; LIMITS_JSON's ``harness``: refuse and report
            imports of the grader's own code, :class:`~kr210_sim.sandbox.harness.Guard`).
    """
    spec, req, ans, guard = prepare(argv)
    try:
        user = load_ik(spec)
    except MemoryError:
        send(ans, {"memory": True})
        return 1
    except IkSpecError as exc:
        send(ans, {**_load_failure(exc), **_blocked(guard)})
        return 1
    send(ans, {"ready": True, "batch": user.batch is not None, **_blocked(guard)})
    while True:
        message = receive(req, None)
        if not isinstance(message, dict):
            return 0
        if "batch" in message:
            poses = [np.asarray(T, dtype=np.float64).reshape(4, 4) for T in message["batch"]]
            q_refs = [np.asarray(q, dtype=np.float64) for q in message["q"]]
            answer = reply_batch(user, poses, q_refs)
        else:
            T = np.asarray(message["T"], dtype=np.float64).reshape(4, 4)
            q_ref = np.asarray(message["q"], dtype=np.float64)
            answer = reply(user.function, T, q_ref)
        notes = user.notes() if user.notes is not None else []
        if notes:
            answer["notes"] = [short(n, 400) for n in notes[:MAX_NOTES]]
        send(ans, {"n": message.get("n"), **answer, **_blocked(guard)})
        if "exit" in answer or "memory" in answer:
            code = answer.get("exit")
            os._exit(code if isinstance(code, int) else 1)


if __name__ == "__main__":
    sys.exit(serve(sys.argv[1:]))
