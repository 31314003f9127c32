"""The cell layout and run settings: one typed place for every figure of the cell.

All lengths in [m], masses in [kg], angles in [rad], times in [s]; the world frame is the robot
base frame (x towards the shelf, z up). Values follow the published KR210 pick-and-place cell
(listed in ``assets/kr210/README.md``); where we deviate, the field's docstring says why.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from kr210_sim.errors import ConfigError

if TYPE_CHECKING:
    from kr210_sim.cell.sensing import ClutterSpec, ObjectKind, SensorSpec


def _check_positive(name: str, value: float) -> None:
    if not np.isfinite(value) or value <= 0:
        raise ConfigError(f"{name} must be a positive finite number, got {value!r}")


def _check_range(name: str, lo: float, hi: float) -> None:
    if not (np.isfinite(lo) and np.isfinite(hi)) or lo > hi:
        raise ConfigError(f"{name} must be a finite range with low <= high, got ({lo!r}, {hi!r})")


@dataclass(frozen=True, slots=True)
class TargetSpec:
    """The target cylinder (upright).

    Attributes:
        radius: Cylinder radius in [m].
        length: Cylinder length (height) in [m].
        mass: Mass in [kg].
        friction: Sliding friction coefficient. The targets' contact priority (1) is above the
            finger pads', the shelf's and the floor's (0), so this is the coefficient of every
            contact the target makes with them; only the bin floor and the fingertip lips
            (priority 2) use their own.
    """

    radius: float = 0.05
    length: float = 0.25
    mass: float = 0.05
    friction: float = 1.0

    def __post_init__(self) -> None:
        for name in ("radius", "length", "mass", "friction"):
            _check_positive(f"target {name}", getattr(self, name))


#: Width of the shelf's side walls and dividers along the shelf's width [m].
SHELF_POST_WIDTH = 0.1
#: Thickness of the shelf's boards [m].
SHELF_BOARD_THICKNESS = 0.04
#: Radius of the robot's base footprint around the joint_1 axis [m]: nothing of the cell may
#: stand inside it (base_link's mesh reaches 0.59 m at its corners).
ROBOT_BASE_RADIUS = 0.6
#: Height below which :data:`ROBOT_BASE_RADIUS` is kept clear [m] (base and joint_1 housing).
ROBOT_BASE_HEIGHT = 1.0


def _round(x: float) -> float:
    """Round a derived length to 1 nm so sums of published figures stay exact."""
    return round(float(x), 9)


@dataclass(frozen=True, slots=True)
class ShelfSpec:
    """A shelf of ``rows`` boards and ``columns`` compartments, open towards the robot.

    The shelf frame has its origin at the centre of the footprint on the floor; its x axis points
    from the open front into the shelf (towards +x at ``yaw_deg`` = 0, the published cell, whose
    front faces the robot at -x). Slots are numbered row by row from the bottom, and in a row
    from left to right as seen from the robot (from the shelf's -x side), as in the published
    cell.

    Attributes:
        position: Centre of the footprint (x, y) in the base frame [m].
        yaw_deg: Rotation about z [deg]; 0 = open front towards -x.
        rows: Number of boards (rows of slots), 1-5.
        columns: Number of compartments per row, 1-5.
        column_pitch: Distance between neighbouring compartment centres [m].
        row_pitch: Distance between neighbouring board tops [m], one per gap (rows - 1 values).
        bottom: z of the lowest board's top [m].
        depth: Depth of the shelf along its x axis [m].
        height: Height of the top panel's upper surface [m].
        slot_inset: Distance of a slot centre behind the open front [m].
    """

    position: tuple[float, float]
    yaw_deg: float
    rows: int
    columns: int
    column_pitch: float
    row_pitch: tuple[float, ...]
    bottom: float
    depth: float
    height: float
    slot_inset: float

    def __post_init__(self) -> None:
        for name in ("column_pitch", "bottom", "depth", "height", "slot_inset"):
            _check_positive(f"shelf {name}", getattr(self, name))
        if len(self.row_pitch) != self.rows - 1:
            raise ConfigError(
                f"shelf row_pitch needs {self.rows - 1} values, got {len(self.row_pitch)}"
            )
        for p in self.row_pitch:
            _check_positive("shelf row_pitch", p)

    @property
    def board_tops(self) -> tuple[float, ...]:
        """z of each board's top surface, bottom row first [m]."""
        tops = [self.bottom]
        for p in self.row_pitch:
            tops.append(_round(tops[-1] + p))
        return tuple(tops)

    @property
    def half_width(self) -> float:
        """Half the outer width across the compartments [m]."""
        return _round(self.columns * self.column_pitch / 2.0 + SHELF_POST_WIDTH / 2.0)

    @property
    def yaw(self) -> float:
        """Yaw [rad]."""
        return math.radians(self.yaw_deg)

    def to_world(self, local: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """A point of the shelf frame in the base frame [m] (rounded to 1 nm)."""
        p = np.asarray(local, dtype=np.float64)
        c, s = _cos_sin(self.yaw_deg)
        x = self.position[0] + c * p[0] - s * p[1]
        y = self.position[1] + s * p[0] + c * p[1]
        return np.array([_round(x), _round(y), _round(p[2])])

    def slot_local(self, number: int) -> tuple[float, float, float]:
        """Slot ``number``'s point on its board, in the shelf frame [m]."""
        row, col = divmod(number - 1, self.columns)
        y = ((self.columns - 1) / 2.0 - col) * self.column_pitch
        return (-self.depth / 2.0 + self.slot_inset, y, self.board_tops[row])


def _cos_sin(yaw_deg: float) -> tuple[float, float]:
    """cos and sin of ``yaw_deg`` [deg], exact at multiples of 90 deg."""
    a = math.radians(yaw_deg)
    return _round(math.cos(a)), _round(math.sin(a))


@dataclass(frozen=True, slots=True)
class BinSpec:
    """The open drop bin (axis-aligned).

    Attributes:
        position: Centre of the footprint (x, y) [m].
        size: Outer extents (x, y) and the rim's height [m].
        wall: Wall thickness [m].
        floor_top: z of the bin floor's top surface [m].
    """

    position: tuple[float, float]
    size: tuple[float, float, float]
    wall: float = 0.06
    floor_top: float = 0.05

    def __post_init__(self) -> None:
        for name, v in zip(("outer_x", "outer_y", "height"), self.size, strict=True):
            _check_positive(f"bin {name}", v)
        for name in ("wall", "floor_top"):
            _check_positive(f"bin {name}", getattr(self, name))

    @property
    def inner_half(self) -> tuple[float, float]:
        """Half the inner extents (x, y) [m]."""
        return (
            _round(self.size[0] / 2.0 - self.wall),
            _round(self.size[1] / 2.0 - self.wall),
        )

    def drop_offsets(self) -> list[tuple[float, float]]:
        """Where successive cylinders are released: offsets of the cylinder's centre from the
        bin's centre [m], a 3x3 grid at half the inner half-extents, centre first.

        The published cell drops every cylinder at one point; released upright on one spot,
        cylinders land on each other and stack into a tower that tops the rim, so we spread
        them (0.22 m apart in the published 1 m bin).
        """
        hx, hy = self.inner_half
        dx, dy = _round(hx / 2.0), _round(hy / 2.0)
        return [(i, j) for j in (0.0, dy, -dy) for i in (0.0, dx, -dx)]


@dataclass(frozen=True, slots=True)
class ObstacleSpec:
    """A box in the cell.

    Attributes:
        position: Centre (x, y, z) [m].
        size: Full extents (x, y, z) before the yaw [m].
        yaw_deg: Rotation about z [deg].
    """

    position: tuple[float, float, float]
    size: tuple[float, float, float]
    yaw_deg: float = 0.0

    def __post_init__(self) -> None:
        for v in self.size:
            _check_positive("obstacle size", v)


@dataclass(frozen=True, slots=True)
class CellConfig:
    """A whole cell: shelf, bin, obstacles, targets and where spare targets wait.

    Cells are read from TOML files (:mod:`kr210_sim.cell.toml`); the published one is
    ``scenes/cells/published.toml``. At run time the model compiled from the cell is the source
    of truth (:mod:`kr210_sim.cell.layout`), not this value.

    Attributes:
        name: The cell's name.
        shelf: The shelf.
        bin: The drop bin.
        target: The nominal target cylinder.
        randomization: Per-cycle randomisation ranges (with ``--randomize``).
        obstacles: Boxes in the cell.
        n_targets: Number of target cylinders in the scene (one fresh one per cycle).
        park_origin: Where the first spare cylinder waits (on the floor, out of reach and out of
            every fixed camera's shot) in [m].
        park_spacing: Spacing between parked cylinders along y in [m].
        sha256: Hash of the file the cell was read from ("" when built in code).
        ready_q_deg: The ready pose the arm waits in between cycles, joint_1 to joint_6 [deg]
            (``[robot] ready_q``), or None for the motion settings' default.
        sensors: The RGB-D sensors (``[[sensors]]``; a cell file that declares none gets
            :func:`~kr210_sim.cell.sensing.default_sensors`; none in a cell built in code).
        objects: The object kinds that may clutter the shelf (``[[objects]]``).
        clutter: How the shelf is cluttered each cycle, or None for a tidy shelf.
        pick: The pick list: kind names picked in turn, cycle after cycle ("target" is the
            ``[target]`` cylinder).
    """

    name: str
    shelf: ShelfSpec
    bin: BinSpec
    target: TargetSpec = field(default_factory=TargetSpec)
    randomization: RandomizationSpec = field(default_factory=lambda: RandomizationSpec())
    obstacles: tuple[ObstacleSpec, ...] = ()
    n_targets: int = 10
    park_origin: tuple[float, float] = (-3.2, -4.2)
    park_spacing: float = 0.3
    sha256: str = ""
    ready_q_deg: tuple[float, float, float, float, float, float] | None = None
    sensors: tuple[SensorSpec, ...] = ()
    objects: tuple[ObjectKind, ...] = ()
    clutter: ClutterSpec | None = None
    pick: tuple[str, ...] = ("target",)

    def __post_init__(self) -> None:
        if self.n_targets < 1:
            raise ConfigError(f"n_targets must be >= 1, got {self.n_targets}")
        if self.ready_q_deg is not None and (
            len(self.ready_q_deg) != 6
            or not all(math.isfinite(v) and abs(v) <= 360.0 for v in self.ready_q_deg)
        ):
            raise ConfigError(
                f"ready_q must be 6 joint angles within +-360 deg, got {self.ready_q_deg!r}"
            )

    @property
    def n_slots(self) -> int:
        """Number of slots (rows x columns)."""
        return self.shelf.rows * self.shelf.columns

    def slot(self, number: int) -> npt.NDArray[np.float64]:
        """Centre of a nominal target in slot ``number`` (1-based) in [m].

        Raises:
            ConfigError: When ``number`` is outside 1..rows x columns.
        """
        if not 1 <= number <= self.n_slots:
            raise ConfigError(f"slot must be 1-{self.n_slots} (0 means random), got {number}")
        p = self.shelf.to_world(self.shelf.slot_local(number))
        p[2] = p[2] + self.target.length / 2.0
        return p

    def park_position(self, index: int) -> npt.NDArray[np.float64]:
        """Where spare target ``index`` rests (upright on the floor) in [m]."""
        x, y = self.park_origin
        return np.array([x, y + index * self.park_spacing, self.target.length / 2.0])


@dataclass(frozen=True, slots=True)
class MotionConfig:
    """How the arm moves through one cycle.

    Attributes:
        accel_scale: Joint acceleration limit as a multiple of the velocity limit, in [1/s]
            (acceleration [rad/s^2] = accel_scale * velocity limit [rad/s]).
        jerk_scale: Joint jerk limit as a multiple of the acceleration limit, in [1/s], of the
            joint moves with the gripper empty (to the standoff, back to the ready pose).
        grip_jerk_scale: The same for the moves into, with and out of the grip, in [1/s]: the
            straight lines (approach, lift, retreat) and the carry. The arm's ringing at the
            grasp seats the cylinder and the grip carries its inertia: at ``jerk_scale`` 24
            the approach line raised the lips' peak load by a sixth (p95 over 100 cycles).
        lin_speed: Cartesian speed of straight-line moves in [m/s].
        lin_step: Sample spacing of straight-line moves in [m].
        standoff: Distance of the joint-space approach pose before the grasp pose, along the
            approach direction [m] (the straight-line approach passes the published pre-grasp).
        grasp_dz: Height of the grasp point relative to the target's centre [m].
        lift: Height of the lift after closing [m].
        drop_height: Height of gripper_link above the ground at release [m] (published: 1.6).
        ready_q: Joint state the arm waits in between cycles [rad].
        close_timeout: Longest wait for the grip to settle after closing starts [s].
        release_wait: Wait after opening before the arm leaves the bin [s].
    """

    accel_scale: float = 4.0
    jerk_scale: float = 24.0
    grip_jerk_scale: float = 12.0
    lin_speed: float = 1.0
    lin_step: float = 0.01
    standoff: float = 0.5
    grasp_dz: float = 0.0
    lift: float = 0.04
    drop_height: float = 1.6
    ready_q: tuple[float, float, float, float, float, float] = (0.8, -0.2, 0.2, 0.0, 0.0, 0.0)
    close_timeout: float = 1.0
    release_wait: float = 0.25

    def __post_init__(self) -> None:
        for name in (
            "accel_scale",
            "jerk_scale",
            "grip_jerk_scale",
            "lin_speed",
            "lin_step",
            "standoff",
            "close_timeout",
            "drop_height",
        ):
            _check_positive(f"motion {name}", getattr(self, name))


@dataclass(frozen=True, slots=True)
class RandomizationSpec:
    """Per-cycle randomisation ranges (used with ``--randomize``).

    Attributes:
        xy_offset: Largest offset of the cylinder from its slot centre in x and y [m].
        yaw: Yaw range [rad].
        radius: Radius range [m].
        length: Length range [m].
        mass: Mass range [kg].
        friction: Friction coefficient range.
    """

    xy_offset: float = 0.03
    yaw: tuple[float, float] = (-np.pi, np.pi)
    radius: tuple[float, float] = (0.04, 0.06)
    length: tuple[float, float] = (0.20, 0.30)
    mass: tuple[float, float] = (0.02, 0.5)
    friction: tuple[float, float] = (0.6, 1.5)

    def __post_init__(self) -> None:
        if not np.isfinite(self.xy_offset) or self.xy_offset < 0:
            raise ConfigError(f"xy_offset must be >= 0, got {self.xy_offset!r}")
        for name in ("yaw", "radius", "length", "mass", "friction"):
            _check_range(name, *getattr(self, name))
