"""Cell files: a cell as TOML, checked key by key (compiled by :mod:`kr210_sim.cell.load`).

A cell file has the sections ``[shelf]``, ``[bin]``, ``[target]`` (with ``[target.randomize]``),
``[robot]`` (its ``ready_q``), any number of ``[[obstacles]]``, and the sections about seeing
(``[[sensors]]``, ``[[objects]]``, ``[clutter]``, ``[pick]``:
:mod:`kr210_sim.cell.sensing_toml`); the README lists every key with its unit. A bad file is
one :class:`~kr210_sim.errors.ConfigError` naming the file, the key and what was expected. The
published cell is ``scenes/cells/published.toml``; ``scenes/kr210_cell.xml`` is generated from
it.
"""

from __future__ import annotations

import functools
import hashlib
import math
import tomllib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from kr210_sim.cell.sensing_toml import read_sensing
from kr210_sim.cell.spec import (
    ROBOT_BASE_HEIGHT,
    ROBOT_BASE_RADIUS,
    SHELF_BOARD_THICKNESS,
    SHELF_POST_WIDTH,
    BinSpec,
    CellConfig,
    MotionConfig,
    ObstacleSpec,
    RandomizationSpec,
    ShelfSpec,
    TargetSpec,
)
from kr210_sim.cell.toml_reader import (
    FRICTION_RANGE,
    MASS_RANGE,
    MAX_LENGTH,
    MIN_LENGTH,
    YAW_RANGE,
    Reader,
    is_number,
)
from kr210_sim.errors import ConfigError
from kr210_sim.robot.description import load_robot
from kr210_sim.util.inputs import read_input
from kr210_sim.util.paths import SCENES_DIR

#: The published cell.
PUBLISHED_CELL = SCENES_DIR / "cells" / "published.toml"
#: Most rows and columns a shelf may have.
MAX_GRID = 5
#: Longest cell name (it heads tables and reports) [characters].
MAX_NAME = 64
#: Largest cell file [bytes].
MAX_FILE_BYTES = 1_000_000

_SECTIONS = {
    "name",
    "shelf",
    "bin",
    "target",
    "obstacles",
    "robot",
    "sensors",
    "objects",
    "clutter",
    "pick",
}
_ROBOT_KEYS = {"ready_q"}
_SHELF_KEYS = {
    "position",
    "yaw_deg",
    "rows",
    "columns",
    "column_pitch",
    "row_pitch",
    "bottom",
    "depth",
    "height",
    "slot_inset",
}
_BIN_KEYS = {"position", "size", "wall", "floor_top"}
_OBSTACLE_KEYS = {"position", "size", "yaw_deg"}
_TARGET_KEYS = {"radius", "length", "mass", "friction", "randomize"}
_RANDOM_KEYS = {"xy_offset", "yaw_deg", "radius", "length", "mass", "friction"}


def _within_joint_limits(path: Path | str, q_deg: tuple[float, ...]) -> None:
    """Refuse a ready pose (``q_deg`` [deg]) outside the robot's joint limits (its URDF's).

    Raises:
        ConfigError: Naming the first joint out of its limits, and the limits [deg].
    """
    robot = load_robot()  # cached per path
    lo, hi = np.degrees(robot.q_lower), np.degrees(robot.q_upper)
    for i, v in enumerate(q_deg):
        if not lo[i] <= v <= hi[i]:
            raise ConfigError(
                f"{path}: [robot] ready_q: joint_{i + 1} = {v:g} deg is outside its limits "
                f"[{lo[i]:g}, {hi[i]:g}] deg"
            )


def parse_cell(text: str, path: Path | str = "<cell>") -> CellConfig:
    """Read a cell from TOML text: each section by its reader, then the layout as a whole.

    Args:
        text: The file's text.
        path: The file's name, for error messages.

    Raises:
        ConfigError: One line naming the file, the key and what was expected.
    """
    path = Path(path)
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML: {exc}") from exc
    unknown = sorted(set(doc) - _SECTIONS)
    if unknown:
        raise ConfigError(
            f"{path}: unknown section or key {unknown[0]!r} "
            f"(expected: {', '.join(sorted(_SECTIONS))})"
        )
    name = _read_name(path, doc.get("name", path.stem))
    for section in ("shelf", "bin"):
        if section not in doc:
            raise ConfigError(f"{path}: [{section}]: missing (required)")
    shelf = _read_shelf(path, doc["shelf"])
    bin_ = _read_bin(path, doc["bin"])
    target, randomization = _read_target(path, doc.get("target", {}))
    obstacles = _read_obstacles(path, doc.get("obstacles", []))
    ready_q = _read_robot(path, doc["robot"]) if "robot" in doc else None
    sensors, kinds, clutter, pick = read_sensing(path, doc, shelf, bin_)
    cell = CellConfig(
        name=name,
        shelf=shelf,
        bin=bin_,
        target=target,
        randomization=randomization,
        obstacles=obstacles,
        ready_q_deg=ready_q,  # type: ignore[arg-type]
        sensors=sensors,
        objects=kinds,
        clutter=clutter,
        pick=pick,
        sha256=hashlib.sha256(text.encode()).hexdigest(),
    )
    _check_layout(path, cell)
    _check_compartments(path, cell)
    _check_bin_depth(path, cell)
    return cell


def _read_name(path: Path, name: Any) -> str:
    """The cell's ``name`` (default: the file's stem)."""
    if (
        not isinstance(name, str)
        or not name
        or len(name) > MAX_NAME
        or not name.isprintable()
        or name != name.strip()
    ):
        shown = name if not isinstance(name, str) or len(name) <= MAX_NAME else name[:MAX_NAME]
        raise ConfigError(
            f"{path}: name: expected 1 to {MAX_NAME} printable characters without leading or "
            f"trailing spaces, got {shown!r}{'...' if shown is not name else ''}"
        )
    return name


def _read_row_pitch(s: Reader, rows: int) -> tuple[float, ...]:
    """``[shelf] row_pitch``: one number for every gap, or a list of ``rows`` - 1 [m]."""
    raw = s.table.get("row_pitch", 0.0 if rows == 1 else None)
    if isinstance(raw, list):
        if len(raw) != rows - 1:
            s.fail("row_pitch", f"a positive number or a list of {rows - 1} (rows - 1) [m]", raw)
        return tuple(s.vector("row_pitch", rows - 1, positive=True))
    pitch = s.number(
        "row_pitch", 0.0 if rows == 1 else None, (MIN_LENGTH if rows > 1 else 0.0, MAX_LENGTH)
    )
    return (pitch,) * (rows - 1)


def _read_shelf(path: Path, table: Any) -> ShelfSpec:
    """The ``[shelf]`` section."""
    s = Reader(path, "[shelf]", table, _SHELF_KEYS)
    rows = s.integer("rows", 1, MAX_GRID)
    columns = s.integer("columns", 1, MAX_GRID)
    row_pitch = _read_row_pitch(s, rows)
    bottom = s.number("bottom")
    top = bottom + sum(row_pitch)
    shelf: ShelfSpec = _build(
        path,
        "[shelf]",
        lambda: ShelfSpec(
            position=tuple(s.vector("position", 2)),  # type: ignore[arg-type]
            yaw_deg=s.number("yaw_deg", 0.0, YAW_RANGE, "[deg]"),
            rows=rows,
            columns=columns,
            column_pitch=s.number("column_pitch"),
            row_pitch=row_pitch,
            bottom=bottom,
            depth=s.number("depth"),
            height=s.number("height", round(top + (row_pitch[-1] if row_pitch else 0.8), 9)),
            slot_inset=s.number("slot_inset", 0.11),
        ),
    )
    if shelf.height <= top + 0.3:
        s.fail("height", f"more than the top board's top + 0.3 m ({top + 0.3:.3f} m)", shelf.height)
    if shelf.slot_inset >= shelf.depth:
        s.fail("slot_inset", f"less than the depth ({shelf.depth} m)", shelf.slot_inset)
    return shelf


def _read_bin(path: Path, table: Any) -> BinSpec:
    """The ``[bin]`` section."""
    b = Reader(path, "[bin]", table, _BIN_KEYS)
    size = b.vector("size", 3, positive=True)
    wall = b.number("wall", 0.06)
    floor_top = b.number("floor_top", 0.05)
    if 2 * wall >= min(size[:2]) - 0.1:
        b.fail("size", f"outer x and y larger than two walls ({2 * wall:g} m) + 0.1 m", size)
    if floor_top >= size[2]:
        b.fail("floor_top", f"below the rim ({size[2]:g} m)", floor_top)
    return BinSpec(
        position=tuple(b.vector("position", 2)),  # type: ignore[arg-type]
        size=tuple(size),  # type: ignore[arg-type]
        wall=wall,
        floor_top=floor_top,
    )


def _read_target(path: Path, table: Any) -> tuple[TargetSpec, RandomizationSpec]:
    """The ``[target]`` section and its ``[target.randomize]`` table."""
    t = Reader(path, "[target]", table, _TARGET_KEYS)
    d = TargetSpec()
    target = TargetSpec(
        radius=t.number("radius", d.radius),
        length=t.number("length", d.length),
        mass=t.number("mass", d.mass, MASS_RANGE, "[kg]"),
        friction=t.number("friction", d.friction, FRICTION_RANGE, ""),
    )
    r = Reader(path, "[target.randomize]", t.table.get("randomize", {}), _RANDOM_KEYS)
    dr = RandomizationSpec()
    yaw = r.range_("yaw_deg", (-180.0, 180.0), YAW_RANGE)
    lengths = (MIN_LENGTH, MAX_LENGTH)
    randomization = RandomizationSpec(
        xy_offset=r.number("xy_offset", dr.xy_offset, (0.0, MAX_LENGTH)),
        yaw=(math.radians(yaw[0]), math.radians(yaw[1])),
        radius=r.range_("radius", dr.radius, lengths),
        length=r.range_("length", dr.length, lengths),
        mass=r.range_("mass", dr.mass, MASS_RANGE),
        friction=r.range_("friction", dr.friction, FRICTION_RANGE),
    )
    return target, randomization


def _read_obstacles(path: Path, raw: Any) -> tuple[ObstacleSpec, ...]:
    """The ``[[obstacles]]`` tables."""
    if not isinstance(raw, list):
        raise ConfigError(f"{path}: obstacles: expected [[obstacles]] tables, got {raw!r}")
    obstacles = []
    for i, table in enumerate(raw, start=1):
        o = Reader(path, f"[[obstacles]] #{i}", table, _OBSTACLE_KEYS)
        obstacles.append(
            ObstacleSpec(
                position=tuple(o.vector("position", 3)),  # type: ignore[arg-type]
                size=tuple(o.vector("size", 3, positive=True)),  # type: ignore[arg-type]
                yaw_deg=o.number("yaw_deg", 0.0, YAW_RANGE, "[deg]"),
            )
        )
    return tuple(obstacles)


def _read_robot(path: Path, table: Any) -> tuple[float, ...] | None:
    """The ``[robot]`` section: its ``ready_q`` [deg], or None when it sets none."""
    rb = Reader(path, "[robot]", table, _ROBOT_KEYS)
    if "ready_q" not in rb.table:
        return None
    q = rb.table["ready_q"]
    ok = isinstance(q, list) and len(q) == 6 and all(is_number(v) for v in q)
    if not ok or max(abs(v) for v in q) > 360.0:
        rb.fail("ready_q", "a list of 6 joint angles within +-360 [deg]", q)
    ready_q = tuple(float(v) for v in q)
    _within_joint_limits(path, ready_q)
    return ready_q


def _build(path: Path, section: str, make: Callable[[], Any]) -> Any:
    try:
        return make()
    except ConfigError as exc:
        if str(exc).startswith(str(path)):
            raise
        raise ConfigError(f"{path}: {section}: {exc}") from exc


# -- footprints ------------------------------------------------------------------------------
_Rect = tuple[tuple[float, float], tuple[float, float], float]  # centre, half extents, yaw [rad]


def _corners(rect: _Rect) -> list[tuple[float, float]]:
    (cx, cy), (hx, hy), yaw = rect
    c, s = math.cos(yaw), math.sin(yaw)
    return [
        (cx + c * x - s * y, cy + s * x + c * y)
        for x, y in ((hx, hy), (-hx, hy), (-hx, -hy), (hx, -hy))
    ]


def _overlap(a: _Rect, b: _Rect) -> bool:
    """Whether two rotated rectangles overlap (separating axis test)."""
    ca, cb = _corners(a), _corners(b)
    for yaw in (a[2], b[2]):
        for ax in ((math.cos(yaw), math.sin(yaw)), (-math.sin(yaw), math.cos(yaw))):
            pa = [x * ax[0] + y * ax[1] for x, y in ca]
            pb = [x * ax[0] + y * ax[1] for x, y in cb]
            if max(pa) <= min(pb) or max(pb) <= min(pa):
                return False
    return True


def _hits_base(rect: _Rect) -> bool:
    """Whether a rectangle reaches into the robot base's disc around the origin."""
    (cx, cy), (hx, hy), yaw = rect
    c, s = math.cos(-yaw), math.sin(-yaw)
    lx, ly = c * -cx - s * -cy, s * -cx + c * -cy  # the origin in the rectangle's frame
    dx, dy = max(abs(lx) - hx, 0.0), max(abs(ly) - hy, 0.0)
    return math.hypot(dx, dy) < ROBOT_BASE_RADIUS


def shelf_rect(shelf: ShelfSpec) -> _Rect:
    """The shelf's footprint."""
    return (shelf.position, (shelf.depth / 2.0, shelf.half_width), shelf.yaw)


def bin_rect(bin_: BinSpec) -> _Rect:
    """The bin's footprint."""
    return (bin_.position, (bin_.size[0] / 2.0, bin_.size[1] / 2.0), 0.0)


def _check_layout(path: Path, cell: CellConfig) -> None:
    shelf, bin_ = shelf_rect(cell.shelf), bin_rect(cell.bin)
    if _overlap(shelf, bin_):
        raise ConfigError(
            f"{path}: [shelf] position / [bin] position: expected the shelf and the bin apart, "
            f"but their footprints overlap"
        )
    for what, rect in (("[shelf] position", shelf), ("[bin] position", bin_)):
        if _hits_base(rect):
            raise ConfigError(
                f"{path}: {what}: expected a footprint at least {ROBOT_BASE_RADIUS} m from the "
                "robot's joint_1 axis, but it reaches into the robot's base"
            )
    if cell.shelf.column_pitch <= SHELF_POST_WIDTH + 2 * cell.target.radius + 0.05:
        raise ConfigError(
            f"{path}: [shelf] column_pitch: expected more than a post ({SHELF_POST_WIDTH} m), a "
            f"target ({2 * cell.target.radius:g} m) and 0.05 m, got {cell.shelf.column_pitch!r}"
        )
    for i, o in enumerate(cell.obstacles, start=1):
        rect = (
            (o.position[0], o.position[1]),
            (o.size[0] / 2, o.size[1] / 2),
            math.radians(o.yaw_deg),
        )
        bottom = o.position[2] - o.size[2] / 2.0
        if o.position[2] + o.size[2] / 2.0 <= 0.0:
            raise ConfigError(
                f"{path}: [[obstacles]] #{i} position: expected a box above the floor, got "
                f"{list(o.position)!r}"
            )
        top = o.position[2] + o.size[2] / 2.0
        b = cell.bin
        inside = (b.position, b.inner_half, 0.0)
        if bottom < b.size[2] and top > b.floor_top and _overlap(rect, inside):
            raise ConfigError(
                f"{path}: [[obstacles]] #{i} position: expected the box out of the bin's inside "
                f"(a cylinder dropped there must reach the bin's floor), got position "
                f"{list(o.position)!r} size {list(o.size)!r}"
            )
        if bottom < cell.shelf.height and _overlap(rect, shelf):
            raise ConfigError(
                f"{path}: [[obstacles]] #{i} position: expected the box out of the shelf (its "
                f"slots must stay free), got position {list(o.position)!r} size {list(o.size)!r}"
            )
        if bottom < ROBOT_BASE_HEIGHT and _hits_base(rect):
            raise ConfigError(
                f"{path}: [[obstacles]] #{i} position: expected the box clear of the robot's base "
                f"(within {ROBOT_BASE_RADIUS} m of the joint_1 axis below {ROBOT_BASE_HEIGHT} m), "
                f"got position {list(o.position)!r} size {list(o.size)!r}"
            )


def _check_compartments(path: Path, cell: CellConfig) -> None:
    """Refuse a shelf whose lowest compartment cannot hold the target and its lift: a cylinder
    spawned on a board would stand in the board above (or be lifted into it).

    The room is measured from a board's top to the next board's top (the top panel's for the
    top row), less a board and the lift of a pick (:class:`~kr210_sim.cell.spec.MotionConfig`).

    Raises:
        ConfigError: Naming ``[shelf] row_pitch`` (or ``height``, for the top row) when the
            target does not fit, ``[target.randomize] length`` when only its drawn lengths'
            high end does not; with the figures.
    """
    s, length = cell.shelf, cell.target.length
    lift = MotionConfig().lift
    tops = s.board_tops
    gaps = [(p, "row_pitch") for p in s.row_pitch]
    gaps.append((s.height - tops[-1], "height"))
    gap, key = min(gaps)
    room = gap - SHELF_BOARD_THICKNESS - lift  # the longest target that fits [m]
    parts = f"a {SHELF_BOARD_THICKNESS:g} m board and the {lift:g} m lift"
    if length >= room:
        need = SHELF_BOARD_THICKNESS + length + lift
        if key == "height":
            raise ConfigError(
                f"{path}: [shelf] height: expected more than {tops[-1] + need:.3f} m (the top "
                f"board's top {tops[-1]:g} m + the {length:g} m target, {parts}), "
                f"got {s.height!r}"
            )
        got = s.row_pitch[0] if len(set(s.row_pitch)) == 1 else list(s.row_pitch)
        raise ConfigError(
            f"{path}: [shelf] row_pitch: expected more than {need:.3f} m between board tops "
            f"(the {length:g} m target, {parts}), got {got!r}"
        )
    high = cell.randomization.length[1]
    if high >= room:
        raise ConfigError(
            f"{path}: [target.randomize] length: expected a high end below {room:.3f} m (the "
            f"lowest compartment's {gap:.3f} m less {parts}), got "
            f"{list(cell.randomization.length)!r}"
        )


def _check_bin_depth(path: Path, cell: CellConfig) -> None:
    """Refuse a bin too shallow for a target standing on its floor to count: a cycle counts a
    cylinder only with its centre below the rim (:mod:`kr210_sim.score.scoring`), and one that
    lands upright stands with its centre half its length above the floor.

    Raises:
        ConfigError: Naming ``[bin] size`` when the nominal target standing on the floor has
            its centre at or above the rim, ``[target.randomize] length`` when only the longest
            drawn target has; with the figures.
    """
    b, length = cell.bin, cell.target.length
    rim, floor = b.size[2], b.floor_top
    why = "standing on the floor, a cylinder counts only with its centre below the rim"
    if floor + length / 2.0 >= rim:
        raise ConfigError(
            f"{path}: [bin] size: expected a rim above {floor + length / 2.0:.3f} m (the floor's "
            f"top {floor:g} m + half the {length:g} m target: {why}), got {list(b.size)!r}"
        )
    high = cell.randomization.length[1]
    if floor + high / 2.0 >= rim:
        raise ConfigError(
            f"{path}: [target.randomize] length: expected a high end below "
            f"{2.0 * (rim - floor):.3f} m (twice the bin's depth, rim {rim:g} m less floor "
            f"{floor:g} m: {why}), got {list(cell.randomization.length)!r}"
        )


# -- files and models ------------------------------------------------------------------------
def load_cell(path: Path | str) -> CellConfig:
    """Read and check a cell file.

    Raises:
        ConfigError: When the file is missing, unreadable or bad (one line).
    """
    path = Path(path)
    if path.is_dir():
        raise ConfigError(f"--cell {path} is a folder: give a .toml file")
    data = read_input(path, "cell file", MAX_FILE_BYTES)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(f"cannot read cell file {path}: {exc}") from exc
    return parse_cell(text, path)


@functools.cache
def published_cell() -> CellConfig:
    """The published cell (``scenes/cells/published.toml``)."""
    return load_cell(PUBLISHED_CELL)
