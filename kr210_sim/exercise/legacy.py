"""The libraries as a 2017 IK server found them: names they had then, put back.

An IK server of the exercise ran on Python 2.7 with the NumPy of its day. Names it used that
were removed since (``numpy.float``, ``numpy.asscalar``, ``time.clock``, ``collections.Mapping``,
``fractions.gcd``) are put back as the objects they stood for, and ``pickle`` reads and writes
files as Python 2's did: through a file opened in text mode (Python 2 made no difference on
Linux), and Python 2's pickled ``str`` (a NumPy array's data, say) read as bytes-like
Latin-1 text, which NumPy and plain strings take. :func:`install` does this in the process that
runs a ROS-form server, and only there; it never replaces a name that exists.
"""

from __future__ import annotations

import io
import pickle
from typing import Any

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


def _numpy() -> None:
    import numpy as np

    for name, target in NUMPY_ALIASES.items():
        if name not in vars(np):
            try:
                setattr(np, name, _resolve(target))
            except AttributeError:  # pragma: no cover - a NumPy without the target
                pass
    for name, value in NUMPY_CONSTANTS.items():
        if name not in vars(np):
            setattr(np, name, value)
    if "asscalar" not in vars(np):
        np.asscalar = lambda a: a.item()  # type: ignore[attr-defined]
    if "asfarray" not in vars(np):
        setattr(np, "asfarray", lambda a, dtype=np.float64: np.asarray(a, dtype=dtype))  # noqa: B010


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

    if not hasattr(time, "clock"):
        time.clock = time.perf_counter  # type: ignore[attr-defined]
    for name in COLLECTIONS_ABC:
        if not hasattr(collections, name):
            setattr(collections, name, getattr(collections.abc, name))
    if not hasattr(fractions, "gcd"):
        fractions.gcd = math.gcd  # type: ignore[attr-defined]
    if not hasattr(base64, "encodestring"):
        base64.encodestring = base64.encodebytes  # type: ignore[attr-defined]
        base64.decodestring = base64.decodebytes  # type: ignore[attr-defined]


def install() -> None:
    """Put the old names back (see the module doc); safe to call twice."""
    _numpy()
    _pickle()
    _stdlib()
