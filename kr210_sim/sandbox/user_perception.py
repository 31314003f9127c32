"""Bring your own perception: the contract of a user's perception function, its loader, and
the checks its answers pass before anything is planned from them.

The contract (``examples/perception_template.py`` says the same)::

    def perceive(look):
        # look["rgb"]:   (H, W, 3) uint8 colour image (rows top to bottom, RGB order)
        # look["depth"]: (H, W) float32 distance along the optical axis [m]; 0 = no reading
        # look["K"]:     (3, 3) float64 intrinsics [px]: [[fx, 0, cx], [0, fy, cy], [0, 0, 1]],
        #                pixel (u, v) = (column, row), (0, 0) the centre of the top-left pixel
        # look["T_base_camera"]: (4, 4) float64 pose of the camera's optical frame (x right,
        #                y down, z forward) in the robot's base frame [m]: p_base = T @ p_cam
        # look["sensor"]: the sensor's name; look["time"]: simulated time of the look [s]
        # look["pick"]:  the label to pick this cycle; look["pick_list"]: the cell's pick list
        # look["kinds"]: {label: {"shape": "cylinder" | "box" | "sphere", "size": [m, ...],
        #                "rgb": [r, g, b] in [0, 1]}}: the object kinds the cell may hold
        # look["bay"]:   {"center": [x, y, z] m, "yaw": rad, "half": [hx, hy, hz] m}: the
        #                inside of the bay looked at, a box in the base frame turned by yaw
        return [
            {"label": "target", "position": [x, y, z], "axis": [ax, ay, az],
             "confidence": 0.9},
            ...
        ]

Each entry is one object seen: ``label`` (a string, required), ``position`` (its centre in the
base frame [m], three finite numbers, required), ``axis`` (its axis of symmetry, a cylinder's or
a box's up, in the base frame; three finite numbers, not all zero, normalised here; default
``[0, 0, 1]``) and ``confidence`` (a finite number in [0, 1], default 1). The pick is planned
from the entry labelled ``look["pick"]`` with the highest confidence; an empty list means
nothing was seen. A look whose best target entry has a confidence under 0.6 asks for a second
look from the wrist camera, where the cell has one (the function is then called again with that
look). At most :data:`MAX_ENTRIES` entries; a list longer than that, an entry that is not as
above, an exception, no answer within the time limit or ``None`` is the cycle's reason for not
seeing the target (one line naming the function), never a pose.

A SPEC names the function as ``--ik`` names an IK: ``package.module:function`` or
``path/to/file.py:function`` (:func:`load_perception`). The function runs in a process of its
own, in the same jail as a student's IK (:mod:`kr210_sim.sandbox.perception_sandbox`).

This module runs in the user's process too (the harness): it imports only the standard library,
NumPy and the harness.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

from kr210_sim.errors import IkSpecError, PerceptionSpecError, one_line
from kr210_sim.sandbox.user_ik import _is_path, import_user_module

#: Most entries an answer may hold.
MAX_ENTRIES = 64
#: Longest label kept [characters].
MAX_LABEL = 100


@dataclass(frozen=True, slots=True)
class Estimate:
    """One object a user's function says it saw.

    Attributes:
        label: Its label.
        position: Its centre in the base frame [m].
        axis: Its unit axis in the base frame.
        confidence: In [0, 1].
    """

    label: str
    position: tuple[float, float, float]
    axis: tuple[float, float, float]
    confidence: float


class UnusableAnswer(ValueError):
    """An answer that is not a list of entries as the contract says (the message: why)."""


def spec_name(spec: str) -> str:
    """How messages name the function: ``file.py:function`` (the file's name only) or
    ``module:function``."""
    where, _, name = spec.rpartition(":")
    return f"{Path(where).name if _is_path(where) else where}:{name}"


def _flag(spec: str, text: str) -> str:
    """An ``--ik`` loader message said of ``--perception``."""
    return text.replace(f"--ik {spec!r}", f"--perception {spec!r}", 1)


def check_spec(spec: str) -> tuple[str, str]:
    """``(module or file, function name)`` of a SPEC, checked for its form only.

    Raises:
        PerceptionSpecError: No ``:function`` part, an empty side, or a name that is not one.
    """
    where, sep, name = spec.rpartition(":")
    if not sep or not where or not name:
        raise PerceptionSpecError(
            f"--perception {spec!r}: expected package.module:function or path/to/file.py:function"
        )
    if not name.isidentifier():
        raise PerceptionSpecError(f"--perception {spec!r}: {name!r} is not a Python function name")
    return where, name


@lru_cache(maxsize=8)
def load_perception(spec: str) -> Callable[..., Any]:
    """The function a SPEC names (``package.module:function`` or ``path/to/file.py:function``).

    Raises:
        PerceptionSpecError: One line: no such file or module, a syntax error (file and line),
            an exception at import, no such function, or a name that is not callable.
    """
    where, name = check_spec(spec)
    try:
        module = import_user_module(where, spec, "--perception")
    except IkSpecError as exc:
        raise PerceptionSpecError(_flag(spec, str(exc))) from None
    fn = getattr(module, name, None)
    if fn is None:
        raise PerceptionSpecError(f"--perception {spec!r}: {where} has no function {name!r}")
    if not callable(fn):
        raise PerceptionSpecError(
            f"--perception {spec!r}: {where}.{name} is a {type(fn).__name__}, not a function"
        )
    return fn


def _three(entry: dict[str, Any], key: str, i: int, default: Sequence[float] | None) -> list[float]:
    """Entry ``i``'s ``key``: three finite numbers (``default`` when missing)."""
    value = entry.get(key)
    if value is None:
        if default is None:
            raise UnusableAnswer(f"entry {i} has no {key!r}")
        return list(default)
    if isinstance(value, dict):  # the child's note of an array too large to send
        raise UnusableAnswer(f"entry {i}'s {key!r} holds {value.get('size')} numbers, not 3")
    if not isinstance(value, list) or len(value) != 3:
        n = len(value) if isinstance(value, list) else 1
        raise UnusableAnswer(f"entry {i}'s {key!r} holds {n} numbers, not 3")
    try:
        numbers = [float(v) for v in value]
    except (TypeError, ValueError):
        raise UnusableAnswer(f"entry {i}'s {key!r} is not three numbers") from None
    if not all(math.isfinite(v) for v in numbers):
        raise UnusableAnswer(f"entry {i}'s {key!r} holds NaN or infinity: {numbers}")
    return numbers


def _entry(entry: Any, i: int) -> Estimate:
    """One entry of the answer's message, checked."""
    if not isinstance(entry, dict):
        raise UnusableAnswer(f"entry {i} is not a dict")
    if "bad" in entry:
        raise UnusableAnswer(f"entry {i} is {one_line(str(entry['bad']))[:200]}")
    label = entry.get("label")
    if not isinstance(label, str) or not label:
        raise UnusableAnswer(f"entry {i}'s 'label' is not a non-empty string")
    position = _three(entry, "position", i, None)
    axis = _three(entry, "axis", i, (0.0, 0.0, 1.0))
    norm = math.sqrt(sum(a * a for a in axis))
    if norm < 1e-9:
        raise UnusableAnswer(f"entry {i}'s 'axis' is zero")
    c = entry.get("confidence", 1.0)
    if isinstance(c, bool) or not isinstance(c, int | float) or not 0.0 <= float(c) <= 1.0:
        raise UnusableAnswer(f"entry {i}'s 'confidence' is not a number in [0, 1]: {c!r}"[:300])
    x, y, z = position
    ax, ay, az = (a / norm for a in axis)
    return Estimate(label[:MAX_LABEL], (x, y, z), (ax, ay, az), float(c))


def read_answer(message: dict[str, Any]) -> list[Estimate]:
    """The entries of a user's answer, as :mod:`~kr210_sim.sandbox.perception_child` sent it.

    Raises:
        UnusableAnswer: Why the answer cannot be used (one line, without the function's name).
        Exception: The user's function raised: an exception of the same type's name, with its
            message.
    """
    if "raised" in message:
        kind = type(str(message["raised"])[:200], (Exception,), {})
        raise kind(one_line(str(message.get("message", "")))[:2000])
    if message.get("none"):
        raise UnusableAnswer("returned None (an empty list says nothing was seen)")
    if "object" in message:
        why = one_line(str(message.get("why", "")))[:300]
        raise UnusableAnswer(f"returned a {str(message['object'])[:100]}, not a list{why}")
    count = message.get("count")
    if isinstance(count, int) and count > MAX_ENTRIES:
        raise UnusableAnswer(f"returned {count:,} entries (at most {MAX_ENTRIES})")
    entries = message.get("entries")
    if not isinstance(entries, list) or len(entries) > MAX_ENTRIES:
        raise UnusableAnswer("the answer's message holds no list of entries")
    return [_entry(e, i) for i, e in enumerate(entries)]
