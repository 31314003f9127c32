"""Python 2 source read and run as Python 2 did: tabs to the next multiple of 8, fissix's syntax
fixes, integer division, leaking list-comprehension variables, and one line for what cannot be
read."""

from __future__ import annotations

from typing import Any

import pytest

from kr210_sim.errors import IkSpecError
from kr210_sim.exercise.py2 import Notes, compile_py2, python2_indentation, runtime


def run(source: str, name: str = "IK_server.py") -> tuple[dict[str, Any], Notes]:
    """Compile and run ``source`` as the student's file ``name``: its globals and notes."""
    notes = Notes()
    code, was_py2 = compile_py2(source.encode(), f"/submissions/{name}")
    scope: dict[str, Any] = {"__name__": "__main__"}
    if was_py2:
        scope.update(runtime(name, notes))
    exec(code, scope)
    return scope, notes


def test_tabs_advance_to_the_next_multiple_of_eight() -> None:
    """A tab after four spaces, a tab alone and eight spaces are one column for Python 2; a tab
    inside a string literal is left alone."""
    source = 'def f(x):\n\tif x:\n    \ty = 1\n\t\treturn """a\n\tb"""\n        return 0\n'
    fixed = python2_indentation(source)
    assert fixed.split("\n")[1:3] == ["        if x:", "        y = 1"]
    assert fixed.split("\n")[4] == '\tb"""'
    scope, _ = run(
        "x = 1\ndef f():\n\tif x:\n\t    y = 2\n            return y\n        return 0\n"
    )
    assert scope["f"]() == 2


def test_python_2_syntax_runs() -> None:
    source = (
        "import cPickle as pickle\n"
        "from itertools import izip\n"
        "d = {1: 2}\n"
        "out = []\n"
        "for i in xrange(3):\n"
        "    print 'pose', i\n"
        "    out.append(i)\n"
        "try:\n"
        "    raise ValueError, 'bad'\n"
        "except ValueError, e:\n"
        "    msg = str(e)\n"
        "octal = 0777\n"
        "ok = d.has_key(1) and 1 <> 2\n"
        "pairs = zip(out, out)\n"
        "text = `octal`\n"
        "long_number = 10L\n"
    )
    scope, _ = run(source)
    assert scope["out"] == [0, 1, 2] and scope["msg"] == "bad" and scope["octal"] == 511
    assert scope["ok"] is True and scope["pairs"] == [(0, 0), (1, 1), (2, 2)]
    assert scope["text"] == "511" and scope["long_number"] == 10


def test_integer_division_floors_and_is_noted() -> None:
    scope, notes = run(
        "half = 1/2\nquarter = 1.0/4\nk = 7\nk /= 2\nimport numpy as np\na = np.array([3, 4]) / 2\n"
    )
    assert scope["half"] == 0 and scope["quarter"] == 0.25 and scope["k"] == 3
    assert scope["a"].tolist() == [1, 2]
    found = notes.take()
    assert found[0].startswith("IK_server.py line 1: `1/2` divides integers (1 / 2 = 0 under")
    assert "line 4: `k /= 2`" in found[1]


def test_future_division_is_true_division() -> None:
    scope, notes = run("from __future__ import division\nhalf = 1/2\n")
    assert scope["half"] == 0.5 and not notes.take()


def test_sympy_integers_divide_to_rationals() -> None:
    """sympy's Integer divided to a Rational under Python 2 too."""
    scope, notes = run("from sympy import Integer, pi\nr = Integer(1)/2\nh = pi/2\n")
    assert str(scope["r"]) == "1/2" and str(scope["h"]) == "pi/2" and not notes.take()


def test_list_comprehension_variables_leak_as_in_python_2() -> None:
    """After ``[x for x in xs]`` the variable holds the last item, in a function and at module
    level; overwriting another value of it is noted."""
    source = (
        "def last(xs):\n"
        "    ys = [v * 2 for v in xs if v]\n"
        "    return v, ys\n"
        "def clobber(poses):\n"
        "    out = []\n"
        "    for x in xrange(len(poses)):\n"
        "        wc = [x + 1 for x in poses]\n"
        "        out.append(x)\n"
        "    return out\n"
        "[k for k in range(3)]\n"
        "pairs = [(i, j) for i, j in [(1, 2), (3, 4)]]\n"
    )
    scope, notes = run(source)
    assert scope["last"]([0, 1, 2]) == (2, [2, 4])
    assert scope["clobber"]([5, 6]) == [6, 6]
    assert scope["k"] == 2 and (scope["i"], scope["j"]) == (3, 4)
    assert notes.take() == [
        "IK_server.py line 7: the list comprehension's variable x overwrote x (0 -> 6), as "
        "Python 2's comprehension variables leak into the code around them"
    ]


def test_round_cmp_and_file_are_python_2s() -> None:
    scope, _ = run("a = round(2.5)\nb = round(-0.5)\nc = round(2.675, 2)\nd = cmp(1, 2)\n")
    assert (scope["a"], scope["b"], scope["c"], scope["d"]) == (3.0, -1.0, 2.67, -1)
    assert isinstance(scope["a"], float)


def test_python_3_files_are_compiled_as_they_are() -> None:
    """A file for python3 (its first line says so, or it is no Python 2) keeps Python 3's
    semantics."""
    scope, _ = run("#!/usr/bin/env python3\nhalf = 1/2\nsquares = [v * v for v in (1, 2)]\n")
    assert scope["half"] == 0.5 and "v" not in scope
    scope, _ = run('print("a", end="")\nhalf = 1/2\n')
    assert scope["half"] == 0.5


@pytest.mark.parametrize(
    ("source", "message"),
    [
        (
            "x = 1\nWC = EE - (0.303) * Rrpy(:,2)\n",
            "IK_server.py line 2: `WC = EE - (0.303) * Rrpy(:,2)` cannot be read as Python 2 "
            "(a syntax error at ':')",
        ),
        (
            "theta1 = 1\ntheta2 =\ntheta3 = 2\n",
            "IK_server.py line 2: `theta2 =` cannot be read as Python 2 (a syntax error at the "
            "end of the line)",
        ),
        (
            'def f():\n        x = 1\n        print "x"\n    return x\n',
            "IK_server.py line 4: `return x`: unindent does not match any outer indentation "
            "level, as under Python 2 (which refused it too: the line is at column 4, the code "
            "line before at column 8, a tab counting to the next multiple of 8)",
        ),
        (  # a tab and 8 spaces: column 16 to Python 2, under a line at column 12
            'def f(x):\n    print "x"\n    for i in x:\n            y = i\n'
            "            # the answer\n\t        z = y\n    return z\n",
            "IK_server.py line 6: `z = y`: unexpected indent, as under Python 2 (which refused it "
            "too: the line is at column 16, the code line before at column 12, a tab counting "
            "to the next multiple of 8)",
        ),
    ],
)
def test_what_cannot_be_read_is_one_line(source: str, message: str) -> None:
    with pytest.raises(IkSpecError) as err:
        compile_py2(source.encode(), "/submissions/IK_server.py")
    assert str(err.value) == message


def test_tracebacks_name_the_students_file_and_line() -> None:
    code, _ = compile_py2(b"x = 1\n\ny = undefined_name\n", "/submissions/IK_server.py")
    with pytest.raises(NameError) as err:
        exec(code, {})
    frame = err.traceback[-1]
    assert str(frame.path) == "/submissions/IK_server.py" and frame.lineno + 1 == 3
