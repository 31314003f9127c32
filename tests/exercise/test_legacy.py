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
