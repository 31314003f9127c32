"""Cell files, the sections about seeing: ``[[sensors]]``, ``[[objects]]``, ``[clutter]`` and
``[pick]`` (read by :func:`kr210_sim.cell.toml.parse_cell`, each entry checked key by key with
the same one-line :class:`~kr210_sim.errors.ConfigError` as the rest of the file).

A cell file that declares no sensor gets :func:`default_sensors`; one
that declares no object kind has no clutter, and its pick list is the cell's own target.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

from kr210_sim.cell.sensing import (
    MOUNTS,
    NOISE_MODELS,
    SHAPES,
    SIZE_FIGURES,
    TARGET_KIND,
    TARGET_RGB,
    WRIST_LOOK_AT,
    WRIST_POSITION,
    ClutterSpec,
    ObjectKind,
    SensorSpec,
)
from kr210_sim.cell.spec import SHELF_BOARD_THICKNESS, SHELF_POST_WIDTH, BinSpec, ShelfSpec
from kr210_sim.cell.toml_reader import MASS_RANGE, MIN_LENGTH, Reader, is_number
from kr210_sim.errors import ConfigError

_SENSOR_KEYS = {
    "name",
    "mount",
    "position",
    "look_at",
    "quaternion",
    "resolution",
    "fovy",
    "range",
    "noise",
    "seed",
}
_OBJECT_KEYS = {"name", "shape", "size", "color", "mass", "friction", "count"}
_CLUTTER_KEYS = {"per_bay", "gap", "seed"}
_PICK_KEYS = {"order"}
#: Cameras every model has (:mod:`kr210_sim.cell.mjcf`): no sensor may take their names but
#: the wrist camera's, ``gripper``, which a sensor on the gripper mount declares.
BUILTIN_CAMERAS = ("overview", "shelf", "bin", "hero")
#: Largest image a sensor renders [px] (the model's offscreen buffer).
MAX_RESOLUTION = (1920, 1088)
#: Most sensors, object kinds, objects of a kind, distractors in a bay and pick-list entries.
MAX_SENSORS = 8
MAX_KINDS = 16
MAX_COUNT = 12
MAX_PER_BAY = 8
MAX_PICKS = 64
#: Radius range of a kind the gripper can pick [m] (the fingertip lips hold nothing thinner,
#: the open fingers take nothing thicker: :func:`kr210_sim.plan.poses.grasp_depth`).
PICK_RADIUS = (0.04, 0.06)
#: Headroom above the tallest object in the lowest compartment [m].
HEADROOM = 0.05
_NAME = re.compile(r"^[a-z][a-z0-9_]{0,31}$")


def read_sensing(
    path: Path, doc: dict[str, Any], shelf: ShelfSpec, bin_: BinSpec
) -> tuple[tuple[SensorSpec, ...], tuple[ObjectKind, ...], ClutterSpec | None, tuple[str, ...]]:
    """The sensors, object kinds, clutter and pick list of a cell file's document.

    Args:
        path: The file's name, for error messages.
        doc: The parsed TOML document.
        shelf: The cell's shelf (objects must fit its bays).
        bin_: The cell's bin (a picked kind must count in it standing on its floor).

    Raises:
        ConfigError: One line naming the file, the entry, the key and what was expected.
    """
    sensors = _read_sensors(path, doc.get("sensors", [])) or default_sensors(shelf)
    kinds = _read_objects(path, doc.get("objects", []), shelf)
    clutter = None
    if "clutter" in doc:
        if not kinds:
            raise ConfigError(f"{path}: [clutter]: needs [[objects]] kinds to draw from")
        clutter = _read_clutter(path, doc["clutter"])
    elif kinds:
        clutter = ClutterSpec()
    pick = _read_pick(path, doc.get("pick", {}), kinds, bin_)
    return sensors, kinds, clutter, pick


def _entries(path: Path, raw: Any, section: str) -> list[Any]:
    if not isinstance(raw, list):
        raise ConfigError(f"{path}: {section}: expected [[{section}]] tables, got {raw!r}")
    return raw


def _name(r: Reader, taken: set[str], what: str) -> str:
    v = r.table.get("name")
    if not isinstance(v, str) or not _NAME.match(v):
        r.fail("name", "1-32 lower-case letters, digits or underscores, starting with a letter", v)
    name = str(v)
    if name in taken:
        r.fail("name", f"a name no other {what} has", name)
    taken.add(name)
    return name


def _choice(r: Reader, key: str, options: tuple[str, ...], default: str | None) -> str:
    v = r.table.get(key, default)
    if v not in options:
        r.fail(key, f"one of {', '.join(repr(o) for o in options)}", v)
    return str(v)


def _read_sensors(path: Path, raw: Any) -> tuple[SensorSpec, ...]:
    """The ``[[sensors]]`` tables (none: the defaults)."""
    entries = _entries(path, raw, "sensors")
    if len(entries) > MAX_SENSORS:
        raise ConfigError(f"{path}: sensors: expected at most {MAX_SENSORS}, got {len(entries)}")
    taken: set[str] = set()
    out = []
    for i, table in enumerate(entries, start=1):
        r = Reader(path, f"[[sensors]] #{i}", table, _SENSOR_KEYS)
        name = _name(r, taken, "sensor")
        mount = _choice(r, "mount", MOUNTS, "world")
        if name in BUILTIN_CAMERAS:
            r.fail("name", f"not a built-in camera's ({', '.join(BUILTIN_CAMERAS)})", name)
        if name == "gripper" and mount != "gripper":
            r.fail("mount", "'gripper' for the sensor named 'gripper' (the wrist camera)", mount)
        position = tuple(r.vector("position", 3))
        has_at, has_q = "look_at" in r.table, "quaternion" in r.table
        if has_at == has_q:
            raise ConfigError(
                f"{path}: [[sensors]] #{i}: expected look_at or quaternion (one of them), got "
                f"{'both' if has_at else 'neither'}"
            )
        look_at = quaternion = None
        if has_at:
            look_at = tuple(r.vector("look_at", 3))
            d = [a - b for a, b in zip(look_at, position, strict=True)]
            n = math.sqrt(sum(x * x for x in d))
            if n < 0.01 or math.hypot(d[0], d[1]) < 1e-3 * n:
                r.fail("look_at", "a point at least 0.01 m away and not straight above or below", d)
        else:
            q = r.table["quaternion"]
            ok = isinstance(q, list) and len(q) == 4 and all(is_number(v) for v in q)
            if not ok or math.sqrt(sum(v * v for v in q)) < 1e-6:
                r.fail("quaternion", "4 numbers [w, x, y, z], not all zero", q)
            quaternion = tuple(float(v) for v in q)
        res = r.table.get("resolution", [640, 480])
        good = isinstance(res, list) and len(res) == 2 and all(type(v) is int for v in res)
        if not good or not all(16 <= v <= m for v, m in zip(res, MAX_RESOLUTION, strict=True)):
            r.fail("resolution", f"[width, height] from 16 to {list(MAX_RESOLUTION)} px", res)
        near, far = r.range_("range", (0.16, 10.0), (MIN_LENGTH, 100.0))
        if near >= far:
            r.fail("range", "[near, far] with near < far [m]", [near, far])
        seed = r.table.get("seed", 0)
        if type(seed) is not int or not 0 <= seed < 2**32:
            r.fail("seed", "a whole number from 0 to 2^32 - 1", seed)
        out.append(
            SensorSpec(
                name=name,
                mount=mount,
                position=position,  # type: ignore[arg-type]
                look_at=look_at,  # type: ignore[arg-type]
                quaternion=quaternion,  # type: ignore[arg-type]
                resolution=(int(res[0]), int(res[1])),
                fovy_deg=r.number("fovy", 58.0, (1.0, 170.0), "[deg]"),
                near=near,
                far=far,
                noise=_choice(r, "noise", NOISE_MODELS, "d415"),
                seed=int(seed),
            )
        )
    return tuple(out)


def _read_objects(path: Path, raw: Any, shelf: ShelfSpec) -> tuple[ObjectKind, ...]:
    """The ``[[objects]]`` tables: object kinds, each fitting the shelf's bays."""
    entries = _entries(path, raw, "objects")
    if len(entries) > MAX_KINDS:
        raise ConfigError(f"{path}: objects: expected at most {MAX_KINDS}, got {len(entries)}")
    taken = {TARGET_KIND}
    room = min([*shelf.row_pitch, shelf.height - shelf.board_tops[-1]])
    room -= SHELF_BOARD_THICKNESS + HEADROOM
    bay = min(shelf.column_pitch - SHELF_POST_WIDTH, shelf.depth)
    out: list[ObjectKind] = []
    for i, table in enumerate(entries, start=1):
        r = Reader(path, f"[[objects]] #{i}", table, _OBJECT_KEYS)
        name = _name(r, taken | {"target"}, "object kind")
        shape = _choice(r, "shape", SHAPES, None)
        size = r.vector("size", SIZE_FIGURES[shape], positive=True)
        if min(size) < 0.01:
            r.fail("size", "figures of at least 0.01 m", size)
        rgb = r.table.get("color")
        if not (
            isinstance(rgb, list)
            and len(rgb) == 3
            and all(is_number(v) and 0 <= v <= 1 for v in rgb)
        ):
            r.fail("color", "[r, g, b], each from 0 to 1", rgb)
        count = r.table.get("count", 3)
        if type(count) is not int or not 1 <= count <= MAX_COUNT:
            r.fail("count", f"a whole number from 1 to {MAX_COUNT}", count)
        kind = ObjectKind(
            name=name,
            shape=shape,
            size=tuple(size),
            rgb=(float(rgb[0]), float(rgb[1]), float(rgb[2])),  # type: ignore[index]
            mass=r.number("mass", 0.1, MASS_RANGE, "[kg]"),
            friction=r.number("friction", 0.8, (0.05, 10.0), ""),
            count=int(count),
        )
        if kind.height >= room:
            r.fail("size", f"a height below {room:.3f} m (the lowest compartment's room)", size)
        if 2.0 * kind.footprint_radius >= bay / 2.0:
            r.fail("size", f"a footprint narrower than {bay / 2.0:.3f} m (half a bay)", size)
        for other in out:
            if (other.shape, other.size, other.rgb) == (kind.shape, kind.size, kind.rgb):
                r.fail(
                    "color",
                    f"a look of its own ({other.name!r} has this shape, size and colour)",
                    list(kind.rgb),
                )
        out.append(kind)
    return tuple(out)


def _read_clutter(path: Path, table: Any) -> ClutterSpec:
    """The ``[clutter]`` table."""
    r = Reader(path, "[clutter]", table, _CLUTTER_KEYS)
    d = ClutterSpec()
    per = r.table.get("per_bay", list(d.per_bay))
    ok = isinstance(per, list) and len(per) == 2 and all(type(v) is int for v in per)
    if not ok or not 0 <= per[0] <= per[1] <= MAX_PER_BAY:
        r.fail("per_bay", f"[low, high] whole numbers with 0 <= low <= high <= {MAX_PER_BAY}", per)
    gap = r.range_("gap", d.gap, (0.001, 0.2))
    seed = r.table.get("seed", 0)
    if type(seed) is not int or not 0 <= seed < 2**32:
        r.fail("seed", "a whole number from 0 to 2^32 - 1", seed)
    return ClutterSpec(per_bay=(int(per[0]), int(per[1])), gap=gap, seed=int(seed))


def _read_pick(
    path: Path, table: Any, kinds: tuple[ObjectKind, ...], bin_: BinSpec
) -> tuple[str, ...]:
    """The ``[pick]`` table's ``order``: kinds to pick, in turn (default: the target)."""
    r = Reader(path, "[pick]", table, _PICK_KEYS)
    order = r.table.get("order", [TARGET_KIND])
    if not isinstance(order, list) or not 1 <= len(order) <= MAX_PICKS:
        r.fail("order", f"a list of 1 to {MAX_PICKS} kind names", order)
    by_name = {k.name: k for k in kinds}
    for name in order:
        if name == TARGET_KIND:
            continue
        kind = by_name.get(name) if isinstance(name, str) else None
        if kind is None:
            names = ", ".join([TARGET_KIND, *by_name])
            r.fail("order", f"names of object kinds ({names})", name)
            continue
        if kind.shape != "cylinder" or not PICK_RADIUS[0] <= kind.size[0] <= PICK_RADIUS[1]:
            r.fail(
                "order",
                f"kinds the gripper can pick (cylinders of radius {PICK_RADIUS[0]:g} to "
                f"{PICK_RADIUS[1]:g} m)",
                name,
            )
        rim = bin_.size[2]
        if bin_.floor_top + kind.size[1] / 2.0 >= rim:
            r.fail(
                "order",
                f"kinds shorter than {2.0 * (rim - bin_.floor_top):.3f} m (standing on the bin's "
                "floor, a cylinder counts only with its centre below the rim)",
                name,
            )
    picked = [by_name[n] for n in set(order) if n != TARGET_KIND]
    rgbs = [k.rgb for k in picked]
    if len(set(rgbs)) != len(rgbs) or any(max(map(abs, _sub(c, TARGET_RGB))) < 1e-3 for c in rgbs):
        r.fail(
            "order",
            "kinds of different colours, none the target's (a target is told by its colour)",
            order,
        )
    return tuple(str(n) for n in order)


def default_sensors(shelf: ShelfSpec) -> tuple[SensorSpec, ...]:
    """The sensors of a cell file that declares none: a fixed RGB-D sensor (a RealSense
    D415's noise) 2.3 m in front of the shelf and to its right, at the middle row's height,
    seeing every bay; and the wrist camera (``gripper``, a D435's noise).

    Args:
        shelf: The cell's shelf (the fixed sensor is placed in its frame).
    """
    tops = shelf.board_tops
    mid = round((tops[0] + tops[-1]) / 2.0 + 0.12, 6)
    front = -shelf.depth / 2.0
    position = shelf.to_world((front - 2.3, -0.6, 0.0))
    at = shelf.to_world((front + 0.15, 0.0, 0.0))
    fixed = SensorSpec(
        name="shelf_rgbd",
        mount="world",
        position=(float(position[0]), float(position[1]), round(mid + 0.35, 6)),
        look_at=(float(at[0]), float(at[1]), mid),
        quaternion=None,
        resolution=(640, 480),
        fovy_deg=52.0,
        near=0.16,
        far=10.0,
        noise="d415",
    )
    wrist = SensorSpec(
        name="gripper",
        mount="gripper",
        position=WRIST_POSITION,
        look_at=WRIST_LOOK_AT,
        quaternion=None,
        resolution=(640, 480),
        fovy_deg=70.0,
        near=0.105,
        far=10.0,
        noise="d435",
    )
    return (fixed, wrist)


def _sub(a: tuple[float, ...], b: tuple[float, ...]) -> tuple[float, ...]:
    return tuple(x - y for x, y in zip(a, b, strict=True))
