"""Python 2 source, read and run as Python 2 ran it.

:func:`compile_py2` takes a student's Python 2 file and returns code for this interpreter:

1. **Indentation as Python 2 read it.** A tab advanced to the next multiple of 8 columns, so
   a file that mixes tabs and spaces (which Python 3 refuses) was consistent there. Leading
   tabs are expanded by that rule on every line but those inside multi-line strings.
2. **Syntax** by ``fissix`` (the maintained fork of ``lib2to3``) with its default fixers:
   ``print "x"``, ``xrange``, ``except E, e``, ``dict.has_key``, ``0777``, backticks, ``ur""``,
   ``cPickle``... An implicit relative import (``import utils`` beside it in a package) is made
   explicit only for modules inside a package, as Python 2 resolved it.
3. **Semantics the syntax does not show** (AST rewrites, line numbers kept):

   * ``a / b`` of two integers floors, as Python 2's did (``1/2 == 0``), unless the module
     says ``from __future__ import division``; each line where that changed a result is noted;
   * a list comprehension's loop variables leak into the function (or module) around it, as
     they did: ``x`` is still bound after ``[x for x in xs]``; each line where that overwrote
     another value of the variable is noted.

What cannot be read (a syntax error in the Python 2 source, a construct fissix leaves invalid)
is one :class:`~kr210_sim.errors.IkSpecError` line naming the file, the line and the code
there. The code is compiled with the student's file name, so tracebacks and messages name the
student's lines. Nothing is written beside the student's file.

The noted events (:class:`Notes`) go back with the answers, for the diagnosis: they say in the
student's terms where Python 2 semantics made a difference.
"""

from __future__ import annotations

import ast
import io
import math
import operator
import re
import sys
import tokenize as py_tokenize
from decimal import ROUND_HALF_UP, Decimal
from functools import lru_cache
from pathlib import Path
from types import CodeType
from typing import Any

import numpy as np

from kr210_sim.errors import IkSpecError, one_line

#: fissix fixers not run: implicit relative imports are fixed only inside packages.
_NOT_RUN = ("fissix.fixes.fix_import",)
_FUTURE_DIVISION = re.compile(
    r"^[ \t]*from[ \t]+__future__[ \t]+import[^\n]*\bdivision\b", re.MULTILINE
)
#: Most events kept per kind and line.
MAX_NOTES = 50


class Notes:
    """Events where Python 2 semantics changed what the student's code computed, one line each
    (the first per file, line and kind)."""

    def __init__(self) -> None:
        self.items: list[str] = []
        self._seen: set[tuple[str, int, str]] = set()

    def add(self, where: str, line: int, kind: str, text: str) -> None:
        """Note ``text`` for ``where`` (a file name) line ``line``, once per kind."""
        key = (where, line, kind)
        if key not in self._seen and len(self._seen) < MAX_NOTES:
            self._seen.add(key)
            self.items.append(f"{where} line {line}: {text}")

    def take(self) -> list[str]:
        """The events noted since the last call."""
        out, self.items = self.items, []
        return out


# -- reading ----------------------------------------------------------------------------------
def decode(data: bytes) -> str:
    """The source text: its coding declaration (or UTF-8), else Latin-1 (every byte a
    character); newlines as ``\\n``."""
    try:
        encoding, _ = py_tokenize.detect_encoding(io.BytesIO(data).readline)
        text = data.decode(encoding)
    except (SyntaxError, LookupError, UnicodeDecodeError):
        text = data.decode("latin-1")
    text = text.lstrip("\ufeff")
    return text.replace("\r\n", "\n").replace("\r", "\n")


def _columns(whitespace: str) -> int:
    """The column Python 2 reached after ``whitespace``: a tab to the next multiple of 8, a form
    feed back to 0."""
    col = 0
    for ch in whitespace:
        if ch == "\t":
            col = (col // 8 + 1) * 8
        elif ch == "\f":
            col = 0
        else:
            col += 1
    return col


def _string_lines(source: str) -> set[int]:
    """Lines (1-based) that begin inside a string literal (the 2nd and later lines of a string
    spanning lines), found with fissix's Python 2 tokenizer; none when it cannot tokenize."""
    from fissix.pgen2 import token, tokenize

    inside: set[int] = set()
    try:
        for kind, _, start, end, _ in tokenize.generate_tokens(io.StringIO(source).readline):
            if kind == token.STRING and end[0] > start[0]:
                inside.update(range(start[0] + 1, end[0] + 1))
    except (tokenize.TokenError, IndentationError, SyntaxError):
        pass
    return inside


def python2_indentation(source: str) -> str:
    """``source`` with the leading tabs of each line (but those inside strings) replaced by the
    spaces Python 2 read them as."""
    inside = _string_lines(source)
    out = []
    for n, line in enumerate(source.split("\n"), start=1):
        stripped = line.lstrip(" \t\f")
        ws = line[: len(line) - len(stripped)]
        if n not in inside and ("\t" in ws or "\f" in ws):
            line = " " * _columns(ws) + stripped
        out.append(line)
    return "\n".join(out)


@lru_cache(maxsize=2)
def _tool(in_package: bool) -> Any:
    from fissix.refactor import RefactoringTool, get_fixers_from_package

    fixers = get_fixers_from_package("fissix.fixes")
    if not in_package:
        fixers = [f for f in fixers if f not in _NOT_RUN]
    return RefactoringTool(fixers)


def _line(source: str, n: int) -> str:
    lines = source.split("\n")
    text = lines[n - 1].strip() if 0 < n <= len(lines) else ""
    return text if len(text) <= 120 else text[:117] + "..."


def _unreadable(where: str, source: str, line: int, why: str) -> IkSpecError:
    code = _line(source, line)
    at = f": `{code}`" if code else ""
    return IkSpecError(f"{where} line {line}{at} cannot be read as Python 2 ({one_line(why)})")


def _misindented(where: str, source: str, n: int, msg: str) -> IkSpecError:
    """Line ``n`` indented as Python 2 refused too (``source`` has Python 2's indentation):
    ``msg``, what it said, and the columns of the line and of the code line before it."""
    lines = source.split("\n")

    def column(i: int) -> int:
        return len(lines[i - 1]) - len(lines[i - 1].lstrip(" ")) if 0 < i <= len(lines) else 0

    before = next(
        (
            i
            for i in range(n - 1, 0, -1)
            if lines[i - 1].strip() and not lines[i - 1].lstrip().startswith("#")
        ),
        0,
    )
    code = _line(source, n)
    at = f": `{code}`" if code else ""
    then = f", the code line before at column {column(before)}" if before else ""
    return IkSpecError(
        f"{where} line {n}{at}: {msg}, as under Python 2 (which refused it too: the line is "
        f"at column {column(n)}{then}, a tab counting to the next multiple of 8)"
    )


def to_python3(source: str, filename: str, in_package: bool = False) -> tuple[str, bool]:
    """``source`` (Python 2, indentation already as Python 2 read it) as Python 3 source.

    Returns:
        The source, and whether it was Python 2 (False: it is Python 3 already: its first line
        runs ``python3``, or it does not parse as Python 2, e.g. ``print(x, end="")``).

    Raises:
        IkSpecError: It is neither (the line fissix stopped at and why).
    """
    from fissix.pgen2 import parse, token, tokenize

    where = Path(filename).name
    if source.startswith("#!") and "python3" in source.split("\n", 1)[0]:
        return source, False
    try:
        tree = _tool(in_package).refactor_string(source if source.endswith("\n") else source + "\n",
                                                 filename)  # fmt: skip
    except parse.ParseError as exc:
        line = exc.context[1][0] if exc.context else 0
        if exc.type == token.INDENT:  # the indentation is Python 2's already: it refused it too
            raise _misindented(where, source, line, "unexpected indent") from None
        try:
            compile(source, filename, "exec", dont_inherit=True)
        except SyntaxError:
            at = "the end of the line" if exc.value in ("\n", "") else repr(exc.value)
            raise _unreadable(where, source, line, f"a syntax error at {at}") from None
        return source, False
    except (tokenize.TokenError, IndentationError, SyntaxError) as exc:
        line = getattr(exc, "lineno", None) or (exc.args[1][0] if len(exc.args) > 1 else 0)
        if isinstance(exc, IndentationError):
            raise _misindented(where, source, int(line or 0), str(exc.args[0])) from None
        raise _unreadable(where, source, int(line or 0), str(exc.args[0])) from None
    return str(tree), True


# -- semantics --------------------------------------------------------------------------------
_UNSET = "__py2_unset__"
_DIV = "__py2_div__"
_IDIV = "__py2_idiv__"
_LEAK = "__py2_leak__"


def _names(target: ast.expr) -> list[str] | None:
    """The names a comprehension's target binds (None when it binds anything else)."""
    if isinstance(target, ast.Name):
        return [target.id]
    if isinstance(target, ast.Tuple | ast.List):
        names: list[str] = []
        for elt in target.elts:
            sub = _names(elt)
            if sub is None:
                return None
            names += sub
        return names
    return None


class _Python2Semantics(ast.NodeTransformer):
    """The rewrites of :func:`compile_py2` step 3."""

    def __init__(self, source: str, division: bool) -> None:
        self.source = source
        self.division = division
        self.scopes: list[str] = ["module"]
        self.count = 0

    def _scoped(self, node: ast.AST, kind: str) -> ast.AST:
        self.scopes.append(kind)
        try:
            return self.generic_visit(node)
        finally:
            self.scopes.pop()

    def visit_FunctionDef(self, node: ast.FunctionDef) -> ast.AST:
        return self._scoped(node, "function")

    def visit_AsyncFunctionDef(self, node: ast.AsyncFunctionDef) -> ast.AST:
        return self._scoped(node, "function")

    def visit_ClassDef(self, node: ast.ClassDef) -> ast.AST:
        return self._scoped(node, "class")

    def visit_Lambda(self, node: ast.Lambda) -> ast.AST:
        return self._scoped(node, "lambda")

    def visit_SetComp(self, node: ast.SetComp) -> ast.AST:
        return self._scoped(node, "comprehension")

    def visit_DictComp(self, node: ast.DictComp) -> ast.AST:
        return self._scoped(node, "comprehension")

    def visit_GeneratorExp(self, node: ast.GeneratorExp) -> ast.AST:
        return self._scoped(node, "comprehension")

    def _text(self, node: ast.AST) -> str:
        return one_line(ast.get_source_segment(self.source, node) or "")[:80]

    def visit_BinOp(self, node: ast.BinOp) -> ast.AST:
        self.generic_visit(node)
        if self.division or not isinstance(node.op, ast.Div):
            return node
        call = ast.Call(
            ast.Name(_DIV, ast.Load()),
            [node.left, node.right, ast.Constant(node.lineno), ast.Constant(self._text(node))],
            [],
        )
        return ast.copy_location(call, node)

    def visit_AugAssign(self, node: ast.AugAssign) -> ast.AST:
        self.generic_visit(node)
        if self.division or not isinstance(node.op, ast.Div):
            return node
        if not isinstance(node.target, ast.Name | ast.Attribute | ast.Subscript):
            return node
        load = ast.fix_missing_locations(ast.copy_location(_as_load(node.target), node.target))
        call = ast.Call(
            ast.Name(_IDIV, ast.Load()),
            [load, node.value, ast.Constant(node.lineno), ast.Constant(self._text(node))],
            [],
        )
        return ast.copy_location(ast.Assign([node.target], ast.copy_location(call, node)), node)

    def visit_ListComp(self, node: ast.ListComp) -> ast.AST:
        leaks = self.scopes[-1] in ("module", "function")
        self._scoped(node, "comprehension")
        names = [_names(g.target) for g in node.generators]
        if not leaks or any(n is None for n in names):
            return node
        self.count += 1
        n = self.count
        temps: list[tuple[str, str]] = []
        for g, vars_ in zip(node.generators, names, strict=True):
            assert vars_ is not None
            pairs = [(f"__py2_v{n}_{v}__", v) for v in vars_]
            temps += pairs
            record = ast.List([ast.NamedExpr(ast.Name(t, ast.Store()), ast.Name(v, ast.Load()))
                               for t, v in pairs], ast.Load())  # fmt: skip
            g.ifs = [record, *g.ifs]
        result = f"__py2_lc{n}__"
        parts: list[ast.expr] = [
            ast.NamedExpr(ast.Name(t, ast.Store()), ast.Name(_UNSET, ast.Load())) for t, _ in temps
        ]
        parts.append(ast.NamedExpr(ast.Name(result, ast.Store()), node))
        for t, v in temps:
            leak = ast.Call(
                ast.Name(_LEAK, ast.Load()),
                [ast.Name(t, ast.Load()), ast.Constant(node.lineno), ast.Constant(v)],
                [],
            )
            parts.append(
                ast.IfExp(
                    ast.Compare(
                        ast.Name(t, ast.Load()), [ast.IsNot()], [ast.Name(_UNSET, ast.Load())]
                    ),
                    ast.NamedExpr(ast.Name(v, ast.Store()), leak),
                    ast.Constant(None),
                )
            )
        parts.append(ast.Name(result, ast.Load()))
        out = ast.Subscript(ast.Tuple(parts, ast.Load()), ast.Constant(-1), ast.Load())
        return ast.fix_missing_locations(ast.copy_location(out, node))


def _as_load(target: ast.expr) -> ast.expr:
    if isinstance(target, ast.Name):
        return ast.Name(target.id, ast.Load())
    if isinstance(target, ast.Attribute):
        return ast.Attribute(target.value, target.attr, ast.Load())
    assert isinstance(target, ast.Subscript)
    return ast.Subscript(target.value, target.slice, ast.Load())


def compile_py2(data: bytes, filename: str, in_package: bool = False) -> tuple[CodeType, bool]:
    """The code of a student's Python 2 file (see the module doc), and whether it was Python 2
    (False: a Python 3 file, compiled as it is; it gets none of :func:`runtime`'s names).

    Args:
        data: The file's bytes.
        filename: Its path (what tracebacks and messages name).
        in_package: It lies in a package (a folder with ``__init__.py``): implicit relative
            imports are resolved as Python 2 did.

    Raises:
        IkSpecError: What cannot be read, one line (file, line, code there).
    """
    source = python2_indentation(decode(data))
    where = Path(filename).name
    py3, was_py2 = to_python3(source, filename, in_package)
    try:
        tree = ast.parse(py3, filename)
    except SyntaxError as exc:
        raise _unreadable(where, source, exc.lineno or 0, exc.msg or "a syntax error") from None
    if was_py2:
        division = bool(_FUTURE_DIVISION.search(source))
        tree = _Python2Semantics(py3, division).visit(tree)
        ast.fix_missing_locations(tree)
    try:
        return compile(tree, filename, "exec", dont_inherit=True), was_py2
    except SyntaxError as exc:
        raise _unreadable(where, source, exc.lineno or 0, exc.msg or "a syntax error") from None


# -- what the rewritten code calls ------------------------------------------------------------
def _integral(x: Any) -> bool:
    """A Python 2 integer for ``/``: int (and bool), NumPy integer scalars and arrays (sympy's
    Integer divides to a Rational, as it did)."""
    if isinstance(x, int | np.integer):
        return True
    return isinstance(x, np.ndarray) and x.dtype.kind in "iub"


def _round(number: Any, ndigits: int = 0) -> float:
    """Python 2's ``round``: a float, halves away from zero (of the number's exact value)."""
    value = float(number)
    if not math.isfinite(value):
        return value
    exact = Decimal(value).quantize(Decimal(1).scaleb(-int(ndigits)), rounding=ROUND_HALF_UP)
    return float(exact)


def _cmp(a: Any, b: Any) -> int:
    """Python 2's ``cmp``."""
    return int(a > b) - int(a < b)


def runtime(where: str, notes: Notes) -> dict[str, Any]:
    """The names the rewritten code of file ``where`` calls, and Python 2's builtins that
    Python 3 dropped (``cmp``, ``file``) or changed (``round``), to put in its module's
    namespace before it runs."""
    unset = object()

    def div(a: Any, b: Any, line: int, text: str) -> Any:
        if _integral(a) and _integral(b):
            out = a // b
            if isinstance(a, int | np.integer) and isinstance(b, int | np.integer) and a % b:
                notes.add(where, line, "division", _division_note(text, a, b, out))
            return out
        return a / b

    def idiv(a: Any, b: Any, line: int, text: str) -> Any:
        if _integral(a) and _integral(b):
            out = operator.ifloordiv(a, b)
            if isinstance(b, int | np.integer) and isinstance(a, int | np.integer) and a % b:
                notes.add(where, line, "division", _division_note(text, a, b, out))
            return out
        return operator.itruediv(a, b)

    def leak(new: Any, line: int, name: str) -> Any:
        old = sys._getframe(1).f_locals.get(name, unset)
        if old is not unset and old is not new:
            try:
                same = bool(old == new)
            except Exception:
                same = False
            if not same:
                notes.add(
                    where,
                    line,
                    f"leak {name}",
                    f"the list comprehension's variable {name} overwrote {name} "
                    f"({_short(old)} -> {_short(new)}), as Python 2's comprehension variables "
                    "leak into the code around them",
                )
        return new

    return {
        _DIV: div,
        _IDIV: idiv,
        _LEAK: leak,
        _UNSET: unset,
        "round": _round,
        "cmp": _cmp,
        "file": open,
    }


def _short(value: Any) -> str:
    text = one_line(repr(value))
    return text if len(text) <= 40 else text[:37] + "..."


def _division_note(text: str, a: Any, b: Any, out: Any) -> str:
    expr = text or f"{a} / {b}"
    return (
        f"`{expr}` divides integers ({a} / {b} = {out} under Python 2, as under ROS; "
        f"{a / b:g} in true division): write {a}.0 / {b} if {a / b:g} is meant"
    )
