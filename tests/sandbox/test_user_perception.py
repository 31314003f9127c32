"""A user's perception function: its loader's one-line errors, the child's encoding of what it
returns, and the checks every answer passes (``--perception SPEC``)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from kr210_sim.errors import PerceptionSpecError
from kr210_sim.sandbox.perception_child import describe, read_look, reply
from kr210_sim.sandbox.user_perception import (
    MAX_ENTRIES,
    UnusableAnswer,
    load_perception,
    read_answer,
    spec_name,
)


def test_a_good_answer_is_read_and_its_axis_normalised() -> None:
    out = [{"label": "target", "position": np.array([2.6, 0.0, 1.7]), "axis": (0, 0, 2)}]
    got = read_answer(describe(out))
    assert len(got) == 1
    e = got[0]
    assert e.label == "target" and e.position == pytest.approx((2.6, 0.0, 1.7))
    assert e.axis == pytest.approx((0.0, 0.0, 1.0)) and e.confidence == 1.0


def test_an_empty_list_is_nothing_seen() -> None:
    assert read_answer(describe([])) == []


@pytest.mark.parametrize(
    ("out", "why"),
    [
        (None, "returned None"),
        ({"label": "target"}, "returned a dict, not a list: return a list of dicts, even of one"),
        ("target", "returned a str, not a list"),
        ([{"position": [1, 2, 3]}], "entry 0's 'label' is not a non-empty string"),
        ([{"label": "target"}], "entry 0 has no 'position'"),
        ([{"label": "t", "position": [math.nan, 0, 1]}], "entry 0's 'position' holds NaN"),
        ([{"label": "t", "position": [1, 2]}], "entry 0's 'position' holds 2 numbers, not 3"),
        ([{"label": "t", "position": np.zeros(1000)}], "holds 1000 numbers, not 3"),
        ([{"label": "t", "position": [1, 2, 3], "axis": [0, 0, 0]}], "entry 0's 'axis' is zero"),
        ([{"label": "t", "position": [1, 2, 3], "confidence": 7}], "not a number in [0, 1]: 7"),
        ([{"label": "t", "position": [1, 2, 3], "confidence": [1, 2]}], "not a number in [0, 1]"),
        ([{"label": "t", "position": ["a", "b", "c"]}], "'position' is not numbers"),
        ([{"label": "t", "position": [1, 2, 3]}, "junk"], "entry 1 is a str, not a dict"),
        ([{}] * (MAX_ENTRIES + 1), f"returned {MAX_ENTRIES + 1:,} entries (at most 64)"),
    ],
)
def test_garbage_is_named_not_used(out: object, why: str) -> None:
    with pytest.raises(UnusableAnswer) as caught:
        read_answer(describe(out))
    assert why in str(caught.value)
    assert "\n" not in str(caught.value)


def test_ten_million_entries_cost_one_small_message() -> None:
    huge = [{"label": "t", "position": [0, 0, 0]}] * 10_000_000
    message = describe(huge)
    assert message == {"count": 10_000_000}
    with pytest.raises(UnusableAnswer, match=r"returned 10,000,000 entries \(at most 64\)"):
        read_answer(message)


def test_what_the_function_raised_comes_back_by_name() -> None:
    def broken(look: dict) -> list:
        raise KeyError("depthh")

    message = reply(broken, {})
    assert message["raised"] == "KeyError" and message["cpu"] >= 0.0
    with pytest.raises(Exception, match="depthh") as caught:
        read_answer(message)
    assert type(caught.value).__name__ == "KeyError"


def test_a_look_is_read_back_whole_from_its_raw_bytes() -> None:
    import os

    rgb = np.arange(4 * 5 * 3, dtype=np.uint8).reshape(4, 5, 3)
    depth = np.linspace(0.5, 2.0, 20, dtype=np.float32).reshape(4, 5)
    r, w = os.pipe()
    try:
        os.write(w, rgb.tobytes() + depth.tobytes())
        message = {
            "look": {"K": np.eye(3).tolist(), "T_base_camera": np.eye(4).tolist(), "pick": "t"},
            "arrays": [
                {"name": "rgb", "dtype": "uint8", "shape": [4, 5, 3]},
                {"name": "depth", "dtype": "float32", "shape": [4, 5]},
            ],
        }
        look = read_look(r, message)
    finally:
        os.close(r)
        os.close(w)
    assert np.array_equal(look["rgb"], rgb) and np.array_equal(look["depth"], depth)
    assert look["depth"].dtype == np.float32 and look["K"].shape == (3, 3)
    assert look["T_base_camera"].shape == (4, 4) and look["pick"] == "t"
    look["rgb"][0, 0, 0] = 9  # the user's to change


def test_a_look_over_the_bound_is_refused_before_it_is_read() -> None:
    message = {"arrays": [{"name": "rgb", "dtype": "uint8", "shape": [100_000, 100_000, 3]}]}
    with pytest.raises(ValueError, match="a look of over"):
        read_look(-1, message)  # nothing read: the fd is never touched


@pytest.mark.parametrize(
    ("body", "spec_tail", "message"),
    [
        (None, "missing.py:perceive", "no such file"),
        ("def perceive(look):\n    return [\n", "p.py:perceive", "syntax error in"),
        ("raise RuntimeError('no camera')\n", "p.py:perceive", "raised RuntimeError: no camera"),
        ("def other(look):\n    return []\n", "p.py:perceive", "has no function 'perceive'"),
        ("perceive = 3\n", "p.py:perceive", "is a int, not a function"),
        ("def perceive(look):\n    return []\n", "p.py", "expected package.module:function"),
    ],
)
def test_a_bad_spec_is_one_line_naming_the_flag(
    tmp_path: Path, body: str | None, spec_tail: str, message: str
) -> None:
    if body is not None:
        (tmp_path / "p.py").write_text(body)
    spec = f"{tmp_path}/{spec_tail}"
    with pytest.raises(PerceptionSpecError) as caught:
        load_perception(spec)
    text = str(caught.value)
    assert text.startswith(f"--perception {spec!r}: ") and message in text and "\n" not in text


def test_a_module_spec_loads_and_is_named_short(tmp_path: Path) -> None:
    fn = load_perception("examples.perception_template:perceive")
    assert fn({}) == []
    assert spec_name(f"{tmp_path}/my.py:perceive") == "my.py:perceive"
    assert spec_name("pkg.mod:perceive") == "pkg.mod:perceive"
