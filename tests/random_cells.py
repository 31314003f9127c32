"""Plausible cells drawn at random, and whether ``check`` agrees with ``run`` on them.

:func:`random_cell` draws, from a seed alone, the text of a cell file a user might write: a
shelf facing the robot (1 to 4 rows and columns, other pitches, heights and depths), a bin
elsewhere around the base (other sizes and rim heights), sometimes a target of another size,
zero to three obstacles (columns, walls and beams in the swing, a beam over part of the bin) and
sometimes a ready pose of its own; with ``kind="edge"``, the edges that draw seldom reaches (a
low or high shelf, an obstacle in front of the shelf, a bin near the arm's reach, a ready pose
with joint 1 near +-180 deg). :func:`agreement` checks the cell as ``check`` does and runs
every slot as ``run`` does (in turn, ``rounds`` times, so the carries go to several drop spots):
a slot agrees when check serves it and each of its cycles succeeds with no robot-cell contact,
or check refuses it and none of its cycles does (a cell ``run`` refuses runs none).

Used by ``benchmarks/cell_sweep.py`` (hundreds of cells) and by one test in
``tests/plan/test_cellcheck.py`` (a few).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from kr210_sim.cell.load import compile_cell
from kr210_sim.cell.toml import parse_cell
from kr210_sim.errors import ConfigError, UnservableCellError
from kr210_sim.jobs import refuse_unservable
from kr210_sim.plan.cellcheck import check_cell
from kr210_sim.sim.runner import RunConfig, Runner

#: Attempts at drawing a cell the file's validator accepts, per seed.
ATTEMPTS = 50


def _f(x: float) -> str:
    return f"{x:.3f}"


def _list(xs: list[float]) -> str:
    return "[" + ", ".join(_f(x) for x in xs) + "]"


def _polar(r: float, deg: float) -> tuple[float, float]:
    a = math.radians(deg)
    return r * math.cos(a), r * math.sin(a)


def _draw(rng: np.random.Generator, name: str) -> str:
    """One cell's TOML text (the validator may still refuse it)."""
    lines = [f'name = "{name}"', "", "[shelf]"]
    bearing = float(rng.uniform(-150.0, 150.0))
    distance = float(rng.uniform(1.9, 3.0))
    rows, columns = int(rng.integers(1, 5)), int(rng.integers(1, 5))
    column_pitch = float(rng.uniform(0.6, 1.1))
    bottom = float(rng.uniform(0.3, 1.1))
    depth = float(rng.uniform(0.35, 0.6))
    x, y = _polar(distance + depth / 2.0, bearing)
    lines += [
        f"position = {_list([x, y])}",
        f"yaw_deg = {_f(bearing + float(rng.uniform(-15.0, 15.0)))}",
        f"rows = {rows}",
        f"columns = {columns}",
        f"column_pitch = {_f(column_pitch)}",
    ]
    if rows > 1:
        if rng.random() < 0.5:
            lines.append(f"row_pitch = {_f(float(rng.uniform(0.4, 0.8)))}")
        else:
            lines.append(f"row_pitch = {_list(list(rng.uniform(0.4, 0.8, rows - 1)))}")
    lines += [f"bottom = {_f(bottom)}", f"depth = {_f(depth)}"]
    if rng.random() < 0.3:
        lines.append(f"slot_inset = {_f(float(rng.uniform(0.08, min(0.25, depth - 0.1))))}")

    side = float(rng.choice([-1.0, 1.0]))
    bin_bearing = bearing + side * float(rng.uniform(60.0, 150.0))
    bin_distance = float(rng.uniform(1.5, 2.8))
    bx, by = _polar(bin_distance, bin_bearing)
    size = [
        float(rng.uniform(0.6, 1.2)),
        float(rng.uniform(0.6, 1.2)),
        float(rng.uniform(0.3, 1.2)),
    ]
    lines += ["", "[bin]", f"position = {_list([bx, by])}", f"size = {_list(size)}"]

    if rng.random() < 0.3:
        lines += [
            "",
            "[target]",
            f"radius = {_f(float(rng.uniform(0.035, 0.065)))}",
            f"length = {_f(float(rng.uniform(0.15, 0.35)))}",
        ]

    for _ in range(int(rng.choice([0, 0, 1, 1, 2, 3]))):
        kind = rng.random()
        if kind < 0.5:  # a column in the swing between shelf and bin
            a = float(rng.uniform(min(bearing, bin_bearing), max(bearing, bin_bearing)))
            cx, cy = _polar(float(rng.uniform(1.0, 2.6)), a)
            s = float(rng.uniform(0.15, 0.4))
            h = float(rng.uniform(1.0, 3.0))
            centre, extents, yaw = [cx, cy, h / 2.0], [s, s, h], 0.0
        elif kind < 0.75:  # a wall, radial, low enough to pass over or short enough to pass by
            a = float(rng.uniform(min(bearing, bin_bearing), max(bearing, bin_bearing)))
            r0 = float(rng.uniform(1.2, 2.0))
            length = float(rng.uniform(0.4, 1.3))
            cx, cy = _polar(r0 + length / 2.0, a)
            h = float(rng.uniform(0.8, 1.8))
            centre, extents, yaw = [cx, cy, h / 2.0], [length, 0.2, h], a
        else:  # a beam above the bin, over part of it or all of it
            z = size[2] + float(rng.uniform(0.05, 0.6))
            ox, oy = (float(v) for v in rng.uniform(-0.4, 0.4, 2) * np.array(size[:2]))
            bx2, by2 = float(rng.uniform(0.1, 1.3)), float(rng.uniform(0.1, 0.5))
            centre, extents, yaw = [bx + ox, by + oy, z], [bx2, by2, 0.1], float(rng.uniform(0, 90))
        lines += ["", "[[obstacles]]", f"position = {_list(centre)}", f"size = {_list(extents)}"]
        if yaw:
            lines.append(f"yaw_deg = {_f(yaw)}")

    if rng.random() < 0.4:
        if rng.random() < 0.25:  # anywhere within the limits
            lo = np.array([-185.0, -45.0, -210.0, -350.0, -125.0, -350.0])
            hi = np.array([185.0, 85.0, 65.0, 350.0, 125.0, 350.0])
            q = rng.uniform(lo, hi)
        else:  # an arm folded up, facing anywhere
            q = np.array(
                [
                    rng.uniform(-180.0, 180.0),
                    rng.uniform(-40.0, 20.0),
                    rng.uniform(-30.0, 50.0),
                    rng.choice([0.0, rng.uniform(-180.0, 180.0)]),
                    rng.uniform(-60.0, 60.0),
                    rng.choice([0.0, rng.uniform(-180.0, 180.0)]),
                ]
            )
        lines += ["", "[robot]", f"ready_q = {_list(list(q))}"]
    return "\n".join(lines) + "\n"


def _ready(rng: np.random.Generator, q1: float) -> list[float]:
    """An arm folded up, joint 1 at ``q1`` [deg]."""
    return [
        q1,
        float(rng.uniform(-40.0, 20.0)),
        float(rng.uniform(-30.0, 50.0)),
        float(rng.choice([0.0, rng.uniform(-180.0, 180.0)])),
        float(rng.uniform(-60.0, 60.0)),
        float(rng.choice([0.0, rng.uniform(-180.0, 180.0)])),
    ]


def _draw_edge(rng: np.random.Generator, name: str) -> str:
    """One cell's TOML text at the edges :func:`_draw` seldom or never reaches: a shelf
    standing low (bottom 0.05-0.3 m) or high (1.4-2.3 m), an obstacle just in front of the
    shelf's open front (a column, or a box up to some of its rows, in the approach of some
    slots), a bin near the arm's reach (2.5-3.2 m out), a ready pose with joint 1 near +-180
    deg (facing away, on either side of the limit's turn); one to four of these at once."""
    lines = [f'name = "{name}"', "", "[shelf]"]
    kinds = ["low_high", "approach", "far_bin", "behind"]
    edges = set(rng.choice(kinds, int(rng.integers(1, 5)), replace=False))
    bearing = float(rng.uniform(-150.0, 150.0))
    distance = float(rng.uniform(1.9, 2.7))
    rows, columns = int(rng.integers(1, 4)), int(rng.integers(1, 4))
    column_pitch = float(rng.uniform(0.6, 1.0))
    depth = float(rng.uniform(0.35, 0.6))
    if "low_high" in edges and rng.random() < 0.5:
        bottom = float(rng.uniform(0.05, 0.3))
    elif "low_high" in edges:
        bottom, rows = float(rng.uniform(1.4, 2.3)), min(rows, 2)
    else:
        bottom = float(rng.uniform(0.5, 1.0))
    pitch = float(rng.uniform(0.45, 0.8))
    yaw = bearing + float(rng.uniform(-10.0, 10.0))
    x, y = _polar(distance + depth / 2.0, bearing)
    lines += [
        f"position = {_list([x, y])}",
        f"yaw_deg = {_f(yaw)}",
        f"rows = {rows}",
        f"columns = {columns}",
        f"column_pitch = {_f(column_pitch)}",
    ]
    if rows > 1:
        lines.append(f"row_pitch = {_f(pitch)}")
    lines += [f"bottom = {_f(bottom)}", f"depth = {_f(depth)}"]

    side = float(rng.choice([-1.0, 1.0]))
    bin_bearing = bearing + side * float(rng.uniform(60.0, 150.0))
    far = "far_bin" in edges
    bin_distance = float(rng.uniform(2.5, 3.2) if far else rng.uniform(1.5, 2.5))
    bx, by = _polar(bin_distance, bin_bearing)
    size = [float(v) for v in rng.uniform((0.6, 0.6, 0.3), (1.2, 1.2, 1.1))]
    lines += ["", "[bin]", f"position = {_list([bx, by])}", f"size = {_list(size)}"]

    if "approach" in edges:  # in front of the open front, beside or before some slots
        width = columns * column_pitch
        gap = float(rng.uniform(0.1, 0.5))
        across = float(rng.uniform(-0.6, 0.6)) * width
        a = math.radians(yaw)
        along = (math.cos(a), math.sin(a))  # into the shelf
        lateral = (-math.sin(a), math.cos(a))
        fx, fy = x - along[0] * depth / 2.0, y - along[1] * depth / 2.0  # the front's centre
        if rng.random() < 0.5:  # a column to the floor
            s = float(rng.uniform(0.1, 0.3))
            h = float(rng.uniform(1.0, 3.0))
            extents = [s, s, h]
        else:  # a box up to some of the rows
            s = float(rng.uniform(0.1, 0.3))
            h = bottom + float(rng.uniform(-0.2, 0.4)) + (rows - 1) * pitch * float(rng.random())
            h = max(h, 0.2)
            extents = [s, float(rng.uniform(0.2, 0.8)), h]
        cx = fx - along[0] * (gap + extents[0] / 2.0) + lateral[0] * across
        cy = fy - along[1] * (gap + extents[0] / 2.0) + lateral[1] * across
        lines += [
            "",
            "[[obstacles]]",
            f"position = {_list([cx, cy, extents[2] / 2.0])}",
            f"size = {_list(extents)}",
            f"yaw_deg = {_f(yaw)}",
        ]

    if "behind" in edges:
        q1 = float(rng.choice([-1.0, 1.0])) * float(rng.uniform(170.0, 185.0))
        lines += ["", "[robot]", f"ready_q = {_list(_ready(rng, q1))}"]
    return "\n".join(lines) + "\n"


#: The kinds of draw: what :func:`random_cell` draws with each.
KINDS = {"plain": _draw, "edge": _draw_edge}


@dataclass(frozen=True, slots=True)
class RandomCell:
    """A drawn cell.

    Attributes:
        seed: The seed it was drawn from.
        text: Its TOML text (accepted by the validator).
        refused: Why the validator refused the earlier draws of this seed, one line each.
    """

    seed: int
    text: str
    refused: tuple[str, ...] = ()


def random_cell(seed: int, kind: str = "plain") -> RandomCell:
    """The first cell drawn from ``seed`` that the cell file's validator accepts.

    Args:
        seed: The seed.
        kind: "plain" (:func:`_draw`) or "edge" (:func:`_draw_edge`), see :data:`KINDS`.

    Raises:
        ConfigError: When :data:`ATTEMPTS` draws are all refused.
    """
    rng = np.random.default_rng(seed)
    refused: list[str] = []
    name = f"random_{seed}" if kind == "plain" else f"{kind}_{seed}"
    for _ in range(ATTEMPTS):
        text = KINDS[kind](rng, name)
        try:
            parse_cell(text, f"{name}.toml")
        except ConfigError as exc:
            refused.append(str(exc))
            continue
        return RandomCell(seed, text, tuple(refused))
    raise ConfigError(f"seed {seed}: {ATTEMPTS} draws refused, the last: {refused[-1]}")


@dataclass(frozen=True, slots=True)
class SlotVerdict:
    """What check said of a slot and what run did there.

    Attributes:
        slot: The slot (1-based).
        served: check serves it.
        check_detail: check's reason when it does not.
        outcomes: run's outcome of each of the slot's cycles ("success" or the reason, with
            "+contact" when the robot touched the cell).
        details: run's detail of each failed cycle.
    """

    slot: int
    served: bool
    check_detail: str
    outcomes: tuple[str, ...]
    details: tuple[str, ...] = ()

    @property
    def clean(self) -> tuple[bool, ...]:
        """Whether each cycle succeeded with no robot-cell contact."""
        return tuple(o == "success" for o in self.outcomes)

    @property
    def agrees(self) -> bool:
        """Served and every cycle clean, or refused and none."""
        return all(self.clean) if self.served else not any(self.clean)

    def describe(self) -> str:
        """One line on a disagreement."""
        said = "served" if self.served else f"refused ({self.check_detail[:160]})"
        why = "; ".join(d[:200] for d in self.details)
        return f"slot {self.slot}: check {said}; run {', '.join(self.outcomes)}" + (
            f" ({why})" if why else ""
        )


@dataclass(frozen=True, slots=True)
class CellAgreement:
    """check and run on one cell.

    Attributes:
        cell: The cell.
        slots: One verdict per slot.
        check_seconds: Wall time of the check [s].
        run_seconds: Wall time of the cycles [s].
        ready_note: check's note on the ready pose.
    """

    cell: RandomCell
    slots: tuple[SlotVerdict, ...]
    check_seconds: float
    run_seconds: float
    ready_note: str = ""
    disagreements: tuple[SlotVerdict, ...] = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "disagreements", tuple(s for s in self.slots if not s.agrees))


def agreement(cell: RandomCell, rounds: int = 2) -> CellAgreement:
    """Check ``cell`` and run each slot ``rounds`` times (slots in turn, one run)."""
    import time

    model = compile_cell(parse_cell(cell.text, f"random_{cell.seed}.toml"))
    t0 = time.perf_counter()
    check = check_cell(model)
    t1 = time.perf_counter()
    n = len(check.slots)
    try:
        refuse_unservable(model)
        refused = ""
    except UnservableCellError as exc:
        refused = str(exc)
    runner = Runner(RunConfig(cycles=n * rounds), model=model)
    outcomes: dict[int, list[str]] = {s: [] for s in range(1, n + 1)}
    details: dict[int, list[str]] = {s: [] for s in range(1, n + 1)}
    index = 0
    for _ in range(0 if refused else rounds):
        for slot in range(1, n + 1):
            index += 1
            r = runner.run_cycle(index, slot)
            outcome = "success" if r.success else str(r.reason)
            if r.env_contact_ticks and r.success:
                outcome = "success+contact"
            outcomes[slot].append(outcome)
            if outcome != "success":
                details[slot].append(f"cycle {index}: {r.detail}")
    t2 = time.perf_counter()
    if refused:  # run refuses the cell: none of its cycles runs, none runs clean
        outcomes = {s: ["refused by run"] for s in outcomes}
        details = {s: [refused] for s in details}
    verdicts = tuple(
        SlotVerdict(
            s,
            check.slots[s - 1].served,
            check.slots[s - 1].detail,
            tuple(outcomes[s]),
            tuple(details[s]),
        )
        for s in range(1, n + 1)
    )
    return CellAgreement(cell, verdicts, t1 - t0, t2 - t1, check.ready_note)
