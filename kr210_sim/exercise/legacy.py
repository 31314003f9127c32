"""The libraries as a 2017 IK server found them: names and behaviours they had then, put back,
and each use of them noted.

An IK server of the exercise ran on Python 2.7 with the NumPy (1.11-1.13) and sympy (1.1) of its
day. :func:`install` does this in the process that runs a ROS-form server, and only there:

* **Names** removed since (``numpy.float``, ``numpy.asscalar``, ``time.clock``,
  ``collections.Mapping``, ``fractions.gcd``, ``base64.encodestring``) answer as the objects they
  stood for, through the module's ``__getattr__`` (PEP 562), which Python asks only for a name
  the module does not have: a name that exists is never replaced, and each line that used a
  removed one is noted.
* **Ragged arrays**: ``numpy.array([3, [1, 2]])`` (and ``asarray``, ``asanyarray``) made an
  object array then; NumPy 1.24 and later raise "setting an array element with a sequence".
  Where that is the error, no ``dtype`` was given and the call is the student's (not a
  library's, not ours), the call is made again with ``dtype=object``, as NumPy 1.11-1.13 made
  it, and the line is noted. Any other error, or one with a ``dtype``, is raised as it was.
* ``pickle`` reads and writes files as Python 2's did: through a file opened in text mode (Python
  2 made no difference on Linux), and Python 2's pickled ``str`` (a NumPy array's data, say) read
  as bytes-like Latin-1 text, which NumPy and plain strings take.

The notes (:func:`take_notes`, each starting with :data:`COMPAT`) go back with the answers, so
the verdict names every compatibility a server needed; the Python 2 semantics are
:mod:`kr210_sim.exercise.py2`'s. What else changed and is *not* put back, and why, is in the
how-to on diagnoses (``docs/how-to/diagnoses.md``): sympy 1.13's ``Float(2.0) != 2``, NumPy 2's
scalar promotion (NEP 50), Python 3's ordering of mixed types.
"""

from __future__ import annotations

import functools
import io
import pickle
import sys
import types
from collections.abc import Callable
from pathlib import Path
from typing import Any

#: How every compatibility note begins (the diagnosis tells them from Python 2's).
COMPAT = "compatibility: "
#: Most notes kept (the first use per file, line and kind).
MAX_NOTES = 50
#: The NumPy calls that made object arrays of ragged lists.
RAGGED_CALLS = ("array", "asarray", "asanyarray")
_notes: list[str] = []
_seen: set[tuple[str, int, str]] = set()


def note(kind: str, text: str, depth: int = 2) -> None:
    """Note that the code ``depth`` frames up needed ``kind`` (once per file, line and kind)."""
    try:
        frame = sys._getframe(depth)
    except ValueError:  # pragma: no cover - no such frame
        return
    key = (frame.f_code.co_filename, frame.f_lineno, kind)
    if key in _seen or len(_seen) >= MAX_NOTES or _library(frame.f_code.co_filename):
        return
    _seen.add(key)
    where = Path(frame.f_code.co_filename).name
    _notes.append(f"{COMPAT}{where} line {frame.f_lineno}: {text}")


#: kr210_sim's own folder: its code gets today's behaviours, never the course's.
_OURS = str(Path(__file__).resolve().parents[1]) + "/"


def _library(filename: str) -> bool:
    """Whether ``filename`` is the interpreter's, an installed library's or kr210_sim's (a probe
    such as ``hasattr(numpy, "float")`` there is no use of the student's)."""
    roots = {sys.prefix, sys.base_prefix, sys.exec_prefix, _OURS.rstrip("/")}
    return filename.startswith("<frozen") or any(filename.startswith(r + "/") for r in roots)


def take_notes() -> list[str]:
    """The compatibility notes since the last call."""
    out = _notes[:]
    del _notes[:]
    return out


#: NumPy names removed since 2017, and what they were.
NUMPY_ALIASES = {
    "float": "builtins.float",
    "int": "builtins.int",
    "object": "builtins.object",
    "complex": "builtins.complex",
    "str": "builtins.str",
    "unicode": "builtins.str",
    "long": "builtins.int",
    "bool": "builtins.bool",
    "float_": "numpy.float64",
    "complex_": "numpy.complex128",
    "cfloat": "numpy.complex128",
    "longfloat": "numpy.longdouble",
    "longcomplex": "numpy.clongdouble",
    "clongfloat": "numpy.clongdouble",
    "string_": "numpy.bytes_",
    "unicode_": "numpy.str_",
    "int0": "numpy.intp",
    "uint0": "numpy.uintp",
    "bool8": "numpy.bool_",
    "round_": "numpy.round",
    "product": "numpy.prod",
    "cumproduct": "numpy.cumprod",
    "alltrue": "numpy.all",
    "sometrue": "numpy.any",
    "in1d": "numpy.isin",
    "trapz": "numpy.trapezoid",
    "mat": "numpy.asmatrix",
    "rank": "numpy.ndim",
}
#: NumPy's removed constants.
NUMPY_CONSTANTS = {
    "NaN": float("nan"),
    "Inf": float("inf"),
    "Infinity": float("inf"),
    "PINF": float("inf"),
    "NINF": float("-inf"),
    "infty": float("inf"),
    "PZERO": 0.0,
    "NZERO": -0.0,
}
#: Names moved out of ``collections`` into ``collections.abc`` (Python 3.10).
COLLECTIONS_ABC = (
    "Callable",
    "Container",
    "Hashable",
    "Iterable",
    "Iterator",
    "Mapping",
    "MutableMapping",
    "MutableSequence",
    "MutableSet",
    "Sequence",
    "Set",
    "Sized",
)


def _resolve(dotted: str) -> Any:
    import importlib

    module, _, name = dotted.rpartition(".")
    return getattr(importlib.import_module(module), name)


def _removed_names(module: types.ModuleType, names: dict[str, Callable[[], Any]], had: str) -> None:
    """Answer ``names`` (each made by its function when asked) through ``module.__getattr__``,
    noting each use; ``had``: who had them ("numpy 1.11-1.13")."""
    before = module.__dict__.get("__getattr__")
    if getattr(before, "_kr210_legacy", False):
        return
    today = f"{module.__name__} {getattr(module, '__version__', '')}".strip()
    if module is sys.modules.get("time") or not hasattr(module, "__version__"):
        today = f"Python {sys.version_info[0]}.{sys.version_info[1]}'s {module.__name__}"

    def __getattr__(name: str) -> Any:
        make = names.get(name)
        if make is None:
            if before is not None:
                return before(name)
            raise AttributeError(f"module {module.__name__!r} has no attribute {name!r}")
        note(
            f"name {module.__name__}.{name}",
            f"needed {module.__name__}.{name}, which {had} had and {today} has not",
        )
        return make()

    __getattr__._kr210_legacy = True  # type: ignore[attr-defined]
    module.__getattr__ = __getattr__  # type: ignore[method-assign]


def _missing(module: types.ModuleType, names: dict[str, Callable[[], Any]]) -> dict[str, Any]:
    return {k: v for k, v in names.items() if k not in vars(module)}


def _numpy() -> None:
    import numpy as np

    names: dict[str, Callable[[], Any]] = {
        name: functools.partial(_resolve, target) for name, target in NUMPY_ALIASES.items()
    }
    names.update({name: functools.partial(float, value) for name, value in NUMPY_CONSTANTS.items()})
    names["asscalar"] = lambda: lambda a: a.item()
    names["asfarray"] = lambda: lambda a, dtype=np.float64: np.asarray(a, dtype=dtype)
    _removed_names(np, _missing(np, names), "numpy 1.11-1.13")
    for name in RAGGED_CALLS:
        call = getattr(np, name)
        if not getattr(call, "_kr210_legacy", False):
            setattr(np, name, _ragged(call))


def _ragged(call: Callable[..., Any]) -> Callable[..., Any]:
    """``call`` (``numpy.array`` or a kin) making an object array of a ragged list, as NumPy
    1.11-1.13 did, where today's raises (see the module doc)."""

    @functools.wraps(call)
    def made(obj: Any, *args: Any, **kwargs: Any) -> Any:
        try:
            return call(obj, *args, **kwargs)
        except ValueError as exc:
            dtype = args[0] if args else kwargs.get("dtype")
            if dtype is not None or "inhomogeneous" not in str(exc):
                raise
            if _library(sys._getframe(1).f_code.co_filename):
                raise  # a library's call, or ours: today's NumPy, as they were written for
            kwargs["dtype"] = object
            try:
                out = call(obj, *args[1:], **kwargs)
            except ValueError:
                raise exc from None
        note(
            "ragged",
            f"needed numpy<1.24's ragged arrays: numpy.{call.__name__} of a ragged list "
            f"(shape {out.shape}) made an object array, as numpy 1.11-1.13 did; numpy >= 1.24 "
            "raises 'setting an array element with a sequence'",
        )
        return out

    made._kr210_legacy = True  # type: ignore[attr-defined]
    return made


def _binary(file: Any) -> Any:
    """The bytes under a file opened in text mode (flushed first)."""
    if isinstance(file, io.TextIOBase) and hasattr(file, "buffer"):
        if file.writable():
            file.flush()
        return file.buffer
    return file


_load, _loads, _dump = pickle.load, pickle.loads, pickle.dump


def load(file: Any, *, fix_imports: bool = True, encoding: str = "latin1", errors: str = "strict",
         buffers: Any = None) -> Any:  # fmt: skip
    """``pickle.load`` as Python 2's: a text-mode file read as bytes, Python 2 ``str`` as
    Latin-1."""
    return _load(_binary(file), fix_imports=fix_imports, encoding=encoding, errors=errors,
                 buffers=buffers)  # fmt: skip


def loads(data: Any, *, fix_imports: bool = True, encoding: str = "latin1", errors: str = "strict",
          buffers: Any = None) -> Any:  # fmt: skip
    """``pickle.loads`` with Python 2 ``str`` read as Latin-1 (a ``str`` argument as its
    Latin-1 bytes)."""
    if isinstance(data, str):
        data = data.encode("latin-1")
    return _loads(data, fix_imports=fix_imports, encoding=encoding, errors=errors,
                  buffers=buffers)  # fmt: skip


def dump(obj: Any, file: Any, protocol: int | None = None, **kwargs: Any) -> None:
    """``pickle.dump``, to a text-mode file too."""
    _dump(obj, _binary(file), protocol, **kwargs)


def _pickle() -> None:
    pickle.load, pickle.loads, pickle.dump = load, loads, dump


def _stdlib() -> None:
    import base64
    import collections
    import collections.abc
    import fractions
    import math
    import time

    _removed_names(time, _missing(time, {"clock": lambda: time.perf_counter}), "Python 2.7")
    abc: dict[str, Callable[[], Any]] = {
        name: functools.partial(getattr, collections.abc, name) for name in COLLECTIONS_ABC
    }
    _removed_names(collections, _missing(collections, abc), "Python 2.7")
    _removed_names(fractions, _missing(fractions, {"gcd": lambda: math.gcd}), "Python 2.7")
    old = {"encodestring": lambda: base64.encodebytes, "decodestring": lambda: base64.decodebytes}
    _removed_names(base64, _missing(base64, old), "Python 2.7")


def install() -> None:
    """Put the old names and behaviours back (see the module doc); safe to call twice."""
    _numpy()
    _pickle()
    _stdlib()
