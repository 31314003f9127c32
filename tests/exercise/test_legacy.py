"""The old names a 2017 IK server used, put back; pickle as Python 2's."""

from __future__ import annotations

import collections
import pickle
import time
from pathlib import Path

import numpy as np

from kr210_sim.exercise import legacy


def test_removed_names_come_back_as_what_they_were(tmp_path: Path) -> None:
    legacy.install()
    assert float is float and int is int  # type: ignore[attr-defined]
    assert np.asscalar(np.array([2.5])) == 2.5  # type: ignore[attr-defined]
    assert np.nan != np.nan and np.inf == float("inf")  # type: ignore[attr-defined]
    assert time.clock() > 0  # type: ignore[attr-defined]
    assert collections.Mapping is collections.abc.Mapping  # type: ignore[attr-defined]


def test_pickle_reads_and_writes_through_text_mode_files(tmp_path: Path) -> None:
    legacy.install()
    path = tmp_path / "dh.pkl"
    with open(path, "w") as f:  # text mode, as Python 2 allowed
        pickle.dump({"d7": 0.303, "a": np.arange(3)}, f)
    with open(path) as f:
        got = pickle.load(f)
    assert got["d7"] == 0.303 and got["a"].tolist() == [0, 1, 2]


def test_a_python_2_str_in_a_pickle_is_read_as_latin_1() -> None:
    """Python 2 pickled its str as bytes-like text (protocol 2: SHORT_BINSTRING)."""
    legacy.install()
    data = b"\x80\x02U\x03ab\xe9q\x00."  # Python 2's pickle.dumps('ab\xe9', 2)
    assert pickle.loads(data) == "ab\xe9"


def _fresh(code: str) -> str:
    """``code`` run in a fresh interpreter after :func:`legacy.install` (which changes NumPy for
    its whole process); its standard output."""
    import subprocess
    import sys
    import textwrap

    head = "from kr210_sim.exercise import legacy\nlegacy.install()\nlegacy.install()\n"
    done = subprocess.run(
        [sys.executable, "-c", head + textwrap.dedent(code)],
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    )
    return done.stdout


def test_a_ragged_array_is_an_object_array_as_numpy_1_13_made_it_and_is_noted() -> None:
    """NumPy >= 1.24 raises "setting an array element with a sequence"; the course's made an
    object array. Only that error is turned back: with a dtype, or another error, it raises."""
    out = _fresh(
        """
        import numpy as np
        log = np.array([3, [0.1, 0.2, 0.3]])
        print(log.dtype, log[0], log[1])
        print(np.asarray([[1, 2], [3]]).shape, np.array([1.5, 2]).dtype)
        try:
            np.array([[1, 2], [3]], dtype=float)
        except ValueError as exc:
            print("raised", str(exc).split(".")[0])
        for n in legacy.take_notes():
            print(n)
        print(legacy.take_notes())
        """
    )
    lines = out.splitlines()
    assert lines[0] == "object 3 [0.1, 0.2, 0.3]"
    assert lines[1] == "(2,) float64"
    assert lines[2] == "raised setting an array element with a sequence"
    assert lines[3] == (
        "compatibility: <string> line 6: needed numpy<1.24's ragged arrays: numpy.array of a "
        "ragged list (shape (2,)) made an object array, as numpy 1.11-1.13 did; numpy >= 1.24 "
        "raises 'setting an array element with a sequence'"
    )
    assert lines[4].startswith("compatibility: <string> line 8: needed numpy<1.24's ragged")
    assert lines[5] == "[]"  # taken


def test_each_use_of_a_removed_name_is_noted_once_per_line() -> None:
    out = _fresh(
        """
        import numpy as np, time, collections
        for _ in range(3):
            x = np.float(2) + time.clock() * 0
        from numpy import asscalar
        print(hasattr(collections, "Mapping"), "float" in vars(np))
        try:
            np.no_such_name
        except AttributeError as exc:
            print("AttributeError", exc)
        print(*legacy.take_notes(), sep="\\n")
        """
    )
    lines = out.splitlines()
    assert lines[0] == "True False"  # answered when asked, never put into the module
    assert lines[1] == "AttributeError module 'numpy' has no attribute 'no_such_name'"
    assert lines[2].startswith(
        "compatibility: <string> line 7: needed numpy.float, which numpy 1.11-1.13 had and numpy 2."
    )
    assert lines[3] == (
        "compatibility: <string> line 7: needed time.clock, which Python 2.7 had and Python "
        "3.11's time has not"
    )
    assert lines[4].startswith("compatibility: <string> line 8: needed numpy.asscalar")
    assert lines[5].startswith("compatibility: <string> line 9: needed collections.Mapping")
    assert len(lines) == 6


def test_a_library_s_ragged_array_is_refused_as_today() -> None:
    """Only the student's calls get the course's NumPy: kr210_sim's own (and an installed
    library's) raise as they were written for."""
    out = _fresh(
        """
        from kr210_sim.exercise import legacy as ours
        try:  # code of a module of ours calling numpy.array on a ragged list
            exec(compile("import numpy; numpy.array([1, [2]])", ours.__file__, "exec"))
        except ValueError as exc:
            print("raised", str(exc).split(".")[0])
        print(legacy.take_notes())
        """
    )
    assert out.splitlines() == ["raised setting an array element with a sequence", "[]"]
