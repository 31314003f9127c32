"""The user's side of :class:`~kr210_sim.sandbox.perception_sandbox.PerceptionSandbox`: the
process that imports the user's perception function and answers its looks.

``python -m kr210_sim.sandbox.perception_child SPEC REQUEST_FD ANSWER_FD PARENT_PID LIMITS_JSON``
sets its limits (:func:`~kr210_sim.sandbox.ik_child.set_limits`), imports the SPEC with
:func:`~kr210_sim.sandbox.user_perception.load_perception`, says ``ready`` and then answers looks
read from REQUEST_FD until that pipe closes. A look is one frame of
:mod:`~kr210_sim.sandbox.ik_wire` (its JSON: the small items, and ``arrays``: each image's name,
dtype and shape) followed by the images' raw bytes, in that order (:func:`read_look`); its
answer is one frame (:func:`reply`): the first :data:`~kr210_sim.sandbox.user_perception.
MAX_ENTRIES` entries with their values as lists, and the CPU time the call took.

Everything here runs beside the user's code and can be undone by it: the side that reads the
answers trusts none of them (:func:`~kr210_sim.sandbox.user_perception.read_answer`).
"""

from __future__ import annotations

import os
import sys
import time
from typing import Any

import numpy as np

from kr210_sim.errors import PerceptionSpecError
from kr210_sim.sandbox.ik_child import _blocked, _fault, prepare
from kr210_sim.sandbox.ik_wire import read_exact, receive, send, short
from kr210_sim.sandbox.user_perception import MAX_ENTRIES, MAX_LABEL, load_perception

#: Largest look (all its images) a request may carry [bytes]: a 1920 x 1080 RGB-D look is
#: 14 MB.
MAX_LOOK_BYTES = 64 << 20
#: The images' dtypes a look may carry.
DTYPES = ("uint8", "float32", "float64")
#: Most numbers one value of an entry carries back (a position takes 3).
MAX_VALUE = 16


def read_look(fd: int, message: dict[str, Any]) -> dict[str, Any]:
    """The look a request frame announces: its items, and its arrays read from ``fd``.

    Raises:
        ValueError: The frame announces arrays that are not as :data:`DTYPES` and
            :data:`MAX_LOOK_BYTES` allow, or the pipe ended before them.
    """
    look = dict(message.get("look", {}))
    for key in ("K", "T_base_camera"):
        if key in look:
            n = 3 if key == "K" else 4
            look[key] = np.asarray(look[key], dtype=np.float64).reshape(n, n)
    total = 0
    for spec in message.get("arrays", []):
        dtype = np.dtype(str(spec["dtype"]))
        shape = tuple(int(s) for s in spec["shape"])
        if dtype.name not in DTYPES or any(s < 0 for s in shape):
            raise ValueError(f"an array of {dtype} {shape} is not a look's")
        size = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
        total += size
        if total > MAX_LOOK_BYTES:
            raise ValueError(f"a look of over {MAX_LOOK_BYTES:,} bytes")
        data = read_exact(fd, size, None) if size else b""
        if data is None:
            raise ValueError("the pipe ended inside a look")
        look[str(spec["name"])] = np.frombuffer(bytearray(data), dtype=dtype).reshape(shape)
    return look


def _value(value: Any) -> Any:
    """One value of an entry as JSON: a number list (``{"size": n}`` when longer than
    :data:`MAX_VALUE`), a float, or what it was when it is neither."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except MemoryError:
        raise
    except Exception as exc:
        return {"bad": short(f"{type(value).__name__}: {exc}", 200)}
    if arr.size > MAX_VALUE:
        return {"size": int(arr.size)}
    return arr.reshape(-1).tolist() if arr.ndim else float(arr)


def _entry(entry: Any) -> dict[str, Any]:
    """One entry of the answer as JSON (checked on the grader's side)."""
    if not isinstance(entry, dict):
        return {"bad": short(f"a {type(entry).__name__}, not a dict", 200)}
    out: dict[str, Any] = {}
    label = entry.get("label")
    if label is not None:
        out["label"] = label[:MAX_LABEL] if isinstance(label, str) else repr(type(label))
    for key in ("position", "axis", "confidence"):
        if entry.get(key) is not None:
            value = _value(entry[key])
            if isinstance(value, dict) and "bad" in value:
                return {"bad": f"an entry whose {key!r} is not numbers ({value['bad']})"}
            out[key] = value
    if "confidence" in out and isinstance(out["confidence"], list):
        out["confidence"] = str(out["confidence"])[:100]
    return out


def describe(out: Any) -> dict[str, Any]:
    """The user's answer as a message: ``{"entries": [...]}``, ``{"count": n}`` past
    :data:`~kr210_sim.sandbox.user_perception.MAX_ENTRIES`, ``{"none": True}``, ``{"object":
    type name, "why": text}`` or a fault (:func:`~kr210_sim.sandbox.ik_child._fault`)."""
    if out is None:
        return {"none": True}
    if not isinstance(out, list | tuple):
        why = ": return a list of dicts" + (", even of one" if isinstance(out, dict) else "")
        return {"object": short(type(out).__name__, 100), "why": why}
    if len(out) > MAX_ENTRIES:
        return {"count": len(out)}
    return {"entries": [_entry(e) for e in out]}


def reply(fn: Any, look: dict[str, Any]) -> dict[str, Any]:
    """``fn(look)`` as a message, with ``cpu``: the CPU time it took [s]."""
    t0 = time.process_time()
    try:
        out = describe(fn(look))
    except BaseException as exc:  # every fault of the user's code is an answer
        out = _fault(exc)
    return {**out, "cpu": time.process_time() - t0}


def serve(argv: list[str]) -> int:
    """The user's process: set the limits, import the SPEC, answer looks until the pipe closes.

    Args:
        argv: ``SPEC REQUEST_FD ANSWER_FD PARENT_PID LIMITS_JSON``, as
            :func:`kr210_sim.sandbox.ik_child.serve` takes them.
    """
    spec, req, ans, guard = prepare(argv)
    try:
        fn = load_perception(spec)
    except MemoryError:
        send(ans, {"memory": True})
        return 1
    except PerceptionSpecError as exc:
        send(ans, {"error": short(str(exc)), **_blocked(guard)})
        return 1
    send(ans, {"ready": True, **_blocked(guard)})
    while True:
        message = receive(req, None)
        if not isinstance(message, dict):
            return 0
        try:
            look = read_look(req, message)
        except ValueError as exc:  # the stream is out of step past it: say so and end
            send(ans, {"n": message.get("n"), "object": "look", "why": f": {short(str(exc))}"})
            return 1
        answer = reply(fn, look)
        send(ans, {"n": message.get("n"), **answer, **_blocked(guard)})
        if "exit" in answer or "memory" in answer:
            code = answer.get("exit")
            os._exit(code if isinstance(code, int) else 1)


if __name__ == "__main__":
    sys.exit(serve(sys.argv[1:]))
