"""The cell layout and run settings: one typed place for every figure of the cell.

All lengths in [m], masses in [kg], angles in [rad], times in [s]; the world frame is the robot
base frame (x towards the shelf, z up). Values follow the published KR210 pick-and-place cell
(``shared/KR210.md``); where we deviate, the field's docstring says why.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from kr210_sim.errors import ConfigError


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
            fingers', the shelf's and the floor's (0), so this is the coefficient of every
            contact the target makes with them; only the bin floor (priority 2) uses its own.
    """

    radius: float = 0.05
    length: float = 0.25
    mass: float = 0.05
    friction: float = 1.0

    def __post_init__(self) -> None:
        for name in ("radius", "length", "mass", "friction"):
            _check_positive(f"target {name}", getattr(self, name))


@dataclass(frozen=True, slots=True)
class ShelfSpec:
    """A shelf of three boards and four vertical dividers, open towards the robot (-x side).

    Attributes:
        x_front: x of the front edge (towards the robot) in [m].
        depth: Depth along x in [m].
        half_width: Half the width along y in [m].
        height: Total height in [m].
        board_tops: z of the three board top surfaces, bottom row first, in [m].
        board_thickness: Board thickness in [m].
        divider_y: (inner, outer) |y| of each divider's faces in [m]; dividers are mirrored in y.
        post_y: (inner, outer) |y| of the two outer side walls in [m].
    """

    x_front: float = 2.49
    depth: float = 0.42
    half_width: float = 1.4
    height: float = 3.0
    board_tops: tuple[float, float, float] = (0.789, 1.556, 2.322)
    board_thickness: float = 0.04
    divider_y: tuple[float, float] = (0.4, 0.5)
    post_y: tuple[float, float] = (1.3, 1.4)

    def __post_init__(self) -> None:
        for name in ("depth", "half_width", "height", "board_thickness"):
            _check_positive(f"shelf {name}", getattr(self, name))


@dataclass(frozen=True, slots=True)
class BinSpec:
    """The open drop bin.

    Attributes:
        center_xy: Centre of the bin footprint in [m].
        outer_size: Outer edge length of the square footprint in [m].
        height: Height of the rim above the ground in [m].
        wall: Wall thickness in [m].
        floor_top: z of the bin floor's top surface in [m].
    """

    center_xy: tuple[float, float] = (0.0, 2.5)
    outer_size: float = 1.0
    height: float = 1.0
    wall: float = 0.06
    floor_top: float = 0.05

    def __post_init__(self) -> None:
        for name in ("outer_size", "height", "wall", "floor_top"):
            _check_positive(f"bin {name}", getattr(self, name))

    @property
    def inner_half(self) -> float:
        """Half the inner edge length of the bin in [m]."""
        return self.outer_size / 2.0 - self.wall


#: The nine published spawn slots (cylinder centre), numbered 1-9 row by row from the bottom.
#: The bottom and top rows are lifted onto their board surfaces: the published heights put the
#: cylinder 2-3 mm into the board (0.911 -> 0.914, 2.445 -> 2.447).
DEFAULT_SLOTS: tuple[tuple[float, float, float], ...] = tuple(
    (2.6, y, z) for z in (0.914, 1.681, 2.447) for y in (0.9, 0.0, -0.9)
)


@dataclass(frozen=True, slots=True)
class CellConfig:
    """The whole cell: shelf, slots, bin, targets and where spare targets wait.

    Attributes:
        target: The target cylinder.
        shelf: The shelf.
        bin: The drop bin.
        slots: Cylinder centre of each spawn slot (1-based numbering = index + 1) in [m].
        n_targets: Number of target cylinders in the scene (one fresh one per cycle).
        park_origin: Where the first spare cylinder waits (on the floor, out of reach and out of
            every fixed camera's shot) in [m].
        park_spacing: Spacing between parked cylinders along y in [m].
    """

    target: TargetSpec = field(default_factory=TargetSpec)
    shelf: ShelfSpec = field(default_factory=ShelfSpec)
    bin: BinSpec = field(default_factory=BinSpec)
    slots: tuple[tuple[float, float, float], ...] = DEFAULT_SLOTS
    n_targets: int = 10
    park_origin: tuple[float, float] = (-3.2, -4.2)
    park_spacing: float = 0.3

    def __post_init__(self) -> None:
        if len(self.slots) != 9:
            raise ConfigError(f"the cell has nine slots, got {len(self.slots)}")
        if self.n_targets < 1:
            raise ConfigError(f"n_targets must be >= 1, got {self.n_targets}")

    def slot(self, number: int) -> npt.NDArray[np.float64]:
        """Centre of slot ``number`` (1-9, published numbering) in [m].

        Raises:
            ConfigError: When ``number`` is outside 1-9.
        """
        if not 1 <= number <= 9:
            raise ConfigError(f"slot must be 1-9 (0 means random), got {number}")
        return np.array(self.slots[number - 1], dtype=np.float64)

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
        jerk_scale: Joint jerk limit as a multiple of the acceleration limit, in [1/s].
        lin_speed: Cartesian speed of straight-line moves in [m/s].
        lin_step: Sample spacing of straight-line moves in [m].
        standoff: Distance of the joint-space approach pose before the grasp pose, along the
            approach direction [m] (the straight-line approach passes the published pre-grasp).
        grasp_dz: Height of the grasp point relative to the target's centre [m].
        lift: Height of the lift after closing [m].
        drop_height: Height of gripper_link above the ground at release [m] (published: 1.6).
        drop_spots: Where successive cylinders are released, as offsets of the cylinder's centre
            from the bin's centre [m], used in turn. The published cell drops every cylinder at
            one point, (-0.1, 2.5, 1.6); released upright on the same spot, cylinders land on
            each other and stack into a tower that tops the rim, so we spread them over a grid.
        ready_q: Joint state the arm waits in between cycles [rad].
        close_timeout: Longest wait for the grip to settle after closing starts [s].
        release_wait: Wait after opening before the arm leaves the bin [s].
    """

    accel_scale: float = 4.0
    jerk_scale: float = 12.0
    lin_speed: float = 1.0
    lin_step: float = 0.01
    standoff: float = 0.5
    grasp_dz: float = 0.0
    lift: float = 0.04
    drop_height: float = 1.6
    drop_spots: tuple[tuple[float, float], ...] = tuple(
        (dx, dy) for dy in (0.0, 0.22, -0.22) for dx in (0.0, 0.22, -0.22)
    )
    ready_q: tuple[float, float, float, float, float, float] = (0.8, -0.2, 0.2, 0.0, 0.0, 0.0)
    close_timeout: float = 1.0
    release_wait: float = 0.25

    def __post_init__(self) -> None:
        for name in (
            "accel_scale",
            "jerk_scale",
            "lin_speed",
            "lin_step",
            "standoff",
            "close_timeout",
            "drop_height",
        ):
            _check_positive(f"motion {name}", getattr(self, name))
        if not self.drop_spots:
            raise ConfigError("drop_spots must name at least one spot")


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
