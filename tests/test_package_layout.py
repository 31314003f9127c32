"""The house rules of the package's layout: no import circles (imports inside functions and under
``TYPE_CHECKING`` count too), at most ten modules at the top level, no module over 600 lines,
no build-time code on the run path, and nothing that points outside the repository."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PACKAGE = REPO / "kr210_sim"
MAX_LINES = 600
MAX_TOP_LEVEL = 10


def _modules() -> dict[str, Path]:
    """Every module of the package by dotted name (a package by its ``__init__``)."""
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(REPO).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def _imports(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """The package's modules that module ``name`` imports anywhere in its body (top level,
    inside functions and classes, under ``if TYPE_CHECKING``). ``from a.b import c`` imports
    ``a.b.c`` when that is a module, else ``a.b``."""
    is_package = path.name == "__init__.py"
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names if a.name in modules)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = name.split(".")
                anchor = anchor if is_package else anchor[:-1]
                anchor = anchor[: len(anchor) - (node.level - 1)]
                base = ".".join([*anchor, base] if base else anchor)
            if not base.startswith("kr210_sim"):
                continue
            for alias in node.names:
                full = f"{base}.{alias.name}"
                found.add(full if full in modules else base)
    found.discard(name)
    return {m for m in found if m in modules}


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10_000))
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def _path_in(graph: dict[str, set[str]], comp: list[str]) -> list[str]:
    """One circle through the first module of ``comp``, for the failure message."""
    start, members = comp[0], set(comp)
    paths = {start: [start]}
    todo = [start]
    while todo:
        v = todo.pop(0)
        for w in sorted(graph[v] & members):
            if w == start:
                return [*paths[v], start]
            if w not in paths:
                paths[w] = [*paths[v], w]
                todo.append(w)
    return comp


def test_no_import_circles() -> None:
    modules = _modules()
    graph = {name: _imports(name, path, modules) for name, path in modules.items()}
    assert sum(map(len, graph.values())) > 100  # the parser sees the imports
    assert "kr210_sim.plan.planner" in graph["kr210_sim.sim.runner"]  # a top-level one
    assert "kr210_sim.plan.cellcheck" in graph["kr210_sim.jobs"]  # one inside a function
    circles = [" -> ".join(_path_in(graph, c)) for c in _cycles(graph)]
    assert not circles, "import circles:\n" + "\n".join(circles)


#: Where each part of the package sits in the flow: a module imports only from parts of a lower
#: rank (or its own part). The package's ``__init__`` is the front door and loads the API on
#: first use; it is left out.
FLOW = {
    "_moved": 0,
    "errors": 0,
    "shadowed": 0,
    "util": 1,
    "robot": 2,
    "cell": 3,
    "exercise": 3,
    "sandbox": 4,
    "perception": 5,
    "plan": 5,
    "score": 5,
    "sim": 6,
    "media": 7,
    "sensors": 7,
    "eval": 8,
    "grading": 8,
    "view": 8,
    "envs": 8,
    "jobs": 9,
    "results": 10,
    "api": 11,
    "commands": 12,
    "cli": 13,
    "__main__": 14,
}


def test_imports_follow_the_flow() -> None:
    """errors -> util -> robot -> cell -> plan, score -> sim -> media -> eval, view, envs -> jobs
    -> results -> api -> commands -> cli: no module imports from a part further down the flow or
    beside it."""
    modules = _modules()
    assert {name.split(".")[1] for name in modules if "." in name} == set(FLOW)
    against = []
    for name, path in modules.items():
        if name == "kr210_sim":
            continue
        part = name.split(".")[1]
        for dep in _imports(name, path, modules):
            if dep == "kr210_sim":
                continue
            other = dep.split(".")[1]
            if other != part and FLOW[other] >= FLOW[part]:
                against.append(f"{name} -> {dep}")
    assert not against, "imports against the flow:\n" + "\n".join(sorted(against))


def test_cycle_finder_finds_a_circle() -> None:
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert _cycles(graph) == [["a", "b", "c"]]
    assert _path_in(graph, ["a", "b", "c"]) == ["a", "b", "c", "a"]


def test_at_most_ten_top_level_modules() -> None:
    top = sorted(p.name for p in PACKAGE.glob("*.py"))
    assert len(top) <= MAX_TOP_LEVEL, top


def test_no_module_over_600_lines() -> None:
    sizes = {
        str(p.relative_to(REPO)): len(p.read_text().splitlines()) for p in PACKAGE.rglob("*.py")
    }
    over = {p: n for p, n in sizes.items() if n > MAX_LINES}
    assert not over, f"modules over {MAX_LINES} lines: {over}"


def test_import_and_a_headless_run_load_no_build_time_code(tmp_path: Path) -> None:
    """``import kr210_sim`` and a headless ``run`` load neither trimesh nor the MJCF builder,
    the cell dressing or the mesh generator (they serve the build commands only)."""
    build_time = (
        "trimesh",
        "kr210_sim.cell.mjcf",
        "kr210_sim.cell.dressing",
        "kr210_sim.robot.meshes",
    )
    script = (
        "import sys\n"
        "import kr210_sim\n"
        f"build_time = {build_time!r}\n"
        "def loaded():\n"
        "    return sorted(m for m in sys.modules if m in build_time or m.startswith('trimesh.'))\n"
        "print(loaded())\n"
        "from kr210_sim.cli import main\n"
        f"code = main(['run', '--cycles', '1', '--report', {str(tmp_path / 'run.json')!r}])\n"
        "print(code, loaded())\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, check=True, cwd=tmp_path
    ).stdout.splitlines()
    assert out[0] == "[]"
    assert out[-1] == "0 []"


def test_no_file_points_outside_the_repository() -> None:
    """The project stands alone: no tracked file names the developers' workspace (the shared
    notes folder beside the repository)."""
    files = subprocess.run(
        ["git", "ls-files"], cwd=REPO, capture_output=True, text=True, check=True
    ).stdout.split()
    outside = ("shared" + "/", "../" + "shared", "/work" + "/")
    found = []
    for name in files:
        path = REPO / name
        if not path.is_file() or path.stat().st_size > 2_000_000:
            continue
        try:
            text = path.read_text()
        except UnicodeDecodeError:
            continue
        found += [f"{name}: {s}" for s in outside if s in text]
    assert len(files) > 100 and not found, found


def test_every_exported_name_is_served() -> None:
    """The top level and each subpackage export a handful of names (``__all__``), and every
    one of them is there: the package's own API, each room's front door."""
    import importlib

    import kr210_sim

    assert {"run", "evaluate", "ik_check", "RunReport", "Kr210SimError", "__version__"} <= set(
        kr210_sim.__all__
    )
    for name in kr210_sim.__all__:
        assert getattr(kr210_sim, name) is not None, name
    rooms = sorted(p.name for p in PACKAGE.iterdir() if (p / "__init__.py").is_file())
    assert len(rooms) >= 9, rooms
    for room in rooms:
        module = importlib.import_module(f"kr210_sim.{room}")
        exported = getattr(module, "__all__", None)
        assert exported, f"kr210_sim.{room} exports nothing"
        assert len(exported) <= 10, f"kr210_sim.{room} exports {len(exported)} names"
        for name in exported:
            assert hasattr(module, name), f"kr210_sim.{room}.{name}"


def test_the_top_level_all_lists_every_api_name() -> None:
    import kr210_sim

    assert set(kr210_sim._API) <= set(kr210_sim.__all__)
    assert len(set(kr210_sim.__all__)) == len(kr210_sim.__all__)
