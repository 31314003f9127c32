"""What a cell says about seeing and clutter: its sensors, its object kinds, how the shelf is
cluttered and the pick list (the values; :mod:`kr210_sim.cell.sensing_toml` reads them from a
cell file, :mod:`kr210_sim.cell.sensing_mjcf` puts them in the model).

All lengths in [m], angles in [deg] as the cell file gives them, masses in [kg]; colours are
RGB in [0, 1].
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from kr210_sim.errors import ConfigError

#: Where a sensor is mounted: fixed in the cell (the base frame) or on ``gripper_link``.
MOUNTS = ("world", "gripper")
#: The noise models a sensor may name (:mod:`kr210_sim.sensors.noise`); "none" switches it off.
NOISE_MODELS = ("none", "d415", "d435")
#: The shapes of object kinds.
SHAPES = ("cylinder", "box", "sphere")
#: How many size figures each shape takes: cylinder radius and length, box extents, sphere radius.
SIZE_FIGURES = {"cylinder": 2, "box": 3, "sphere": 1}
#: The kind name of the cell's own target cylinder (the ``[target]`` section).
TARGET_KIND = "target"
#: The colour of the cell's own target cylinder (the model's ``target_<k>`` geoms).
TARGET_RGB = (0.1, 0.35, 0.95)
#: The wrist camera's pose on gripper_link (the camera ``gripper`` of the model): position [m]
#: and the point it looks at [m], in the gripper_link frame.
WRIST_POSITION = (-0.08, 0.0, 0.16)
WRIST_LOOK_AT = (0.35, 0.0, 0.0)


@dataclass(frozen=True, slots=True)
class SensorSpec:
    """An RGB-D sensor: a camera of the model with a range and a noise model.

    Attributes:
        name: The sensor's (and its camera's) name.
        mount: "world" (pose in the base frame) or "gripper" (pose in gripper_link's frame).
        position: The optical centre [m] in the mount's frame.
        look_at: A point the optical axis passes through [m] (image up is world z up for a
            world sensor, the mount's z for one on the gripper), or None when
            ``quaternion`` is given.
        quaternion: The optical frame's orientation (x right, y down, z forward) in the mount's
            frame, (w, x, y, z), or None when ``look_at`` is given.
        resolution: Image width and height [px].
        fovy_deg: Full vertical field of view [deg].
        near: Nearest depth the sensor measures [m] (closer: missing).
        far: Farthest depth the sensor measures [m] (farther: missing).
        noise: The noise model's name (:data:`NOISE_MODELS`), "none" for perfect images.
        seed: The sensor's noise seed (a look's generator is seeded by it and the look's time
            unless the caller passes its own).
    """

    name: str
    mount: str
    position: tuple[float, float, float]
    look_at: tuple[float, float, float] | None
    quaternion: tuple[float, float, float, float] | None
    resolution: tuple[int, int]
    fovy_deg: float
    near: float
    far: float
    noise: str
    seed: int = 0

    def __post_init__(self) -> None:
        if self.mount not in MOUNTS:
            raise ConfigError(f"sensor mount must be one of {MOUNTS}, got {self.mount!r}")
        if (self.look_at is None) == (self.quaternion is None):
            raise ConfigError("a sensor needs look_at or quaternion, not both")
        if not 0.0 < self.near < self.far:
            raise ConfigError(f"sensor range must be 0 < near < far, got {self.near}, {self.far}")
        if self.noise not in NOISE_MODELS:
            raise ConfigError(f"sensor noise must be one of {NOISE_MODELS}, got {self.noise!r}")

    def optical_rotation(self) -> npt.NDArray[np.float64]:
        """The optical frame's rotation in the mount's frame (columns: x right, y down,
        z forward)."""
        if self.quaternion is not None:
            w, x, y, z = np.asarray(self.quaternion, dtype=np.float64) / np.linalg.norm(
                self.quaternion
            )
            return np.array(
                [
                    [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                    [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                    [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
                ]
            )
        assert self.look_at is not None
        fwd = np.subtract(self.look_at, self.position, dtype=np.float64)
        fwd /= np.linalg.norm(fwd)
        right = np.cross(fwd, [0.0, 0.0, 1.0])
        right /= np.linalg.norm(right)
        down = np.cross(fwd, right)
        return np.column_stack((right, down, fwd))

    def mujoco_xyaxes(self) -> tuple[float, ...]:
        """The MuJoCo camera's ``xyaxes`` (x right, y up; it looks along its -z)."""
        R = self.optical_rotation()
        return (*np.round(R[:, 0], 6).tolist(), *np.round(-R[:, 1], 6).tolist())


@dataclass(frozen=True, slots=True)
class ObjectKind:
    """A kind of object that may stand on the shelf.

    Attributes:
        name: The kind's label (lower case letters, digits and underscores).
        shape: "cylinder" (upright), "box" or "sphere".
        size: cylinder (radius, length), box full extents (x, y, z), sphere (radius,) [m].
        rgb: Colour, each channel in [0, 1].
        mass: Mass [kg].
        friction: Sliding friction coefficient.
        count: How many of the kind the model holds (most on the shelf at once).
    """

    name: str
    shape: str
    size: tuple[float, ...]
    rgb: tuple[float, float, float]
    mass: float
    friction: float
    count: int = 3

    def __post_init__(self) -> None:
        if self.shape not in SHAPES:
            raise ConfigError(f"object shape must be one of {SHAPES}, got {self.shape!r}")
        if len(self.size) != SIZE_FIGURES[self.shape]:
            raise ConfigError(
                f"a {self.shape} takes {SIZE_FIGURES[self.shape]} size figures, got {self.size}"
            )

    @property
    def height(self) -> float:
        """Height standing on a board [m]."""
        if self.shape == "cylinder":
            return self.size[1]
        if self.shape == "box":
            return self.size[2]
        return 2.0 * self.size[0]

    @property
    def footprint_radius(self) -> float:
        """Radius of the disc that holds the footprint at any yaw [m]."""
        if self.shape == "box":
            return 0.5 * math.hypot(self.size[0], self.size[1])
        return self.size[0]

    @property
    def half_extents(self) -> tuple[float, float, float]:
        """Half extents of the kind's bounding box, upright, unturned [m]."""
        if self.shape == "cylinder":
            return (self.size[0], self.size[0], self.size[1] / 2.0)
        if self.shape == "box":
            return (self.size[0] / 2.0, self.size[1] / 2.0, self.size[2] / 2.0)
        return (self.size[0],) * 3


@dataclass(frozen=True, slots=True)
class ClutterSpec:
    """How the shelf is cluttered at the start of each cycle.

    Attributes:
        per_bay: Fewest and most distractors in a bay.
        gap: Smallest and largest gap between neighbouring objects' footprints [m] (a small
            gap: they stand touching, or nearly).
        seed: Seed of the clutter drawn without ``--randomize`` (the same shelf for the same
            slot and cycle).
    """

    per_bay: tuple[int, int] = (1, 3)
    gap: tuple[float, float] = (0.002, 0.03)
    seed: int = 0

    def __post_init__(self) -> None:
        if not 0 <= self.per_bay[0] <= self.per_bay[1]:
            raise ConfigError(f"clutter per_bay must be 0 <= low <= high, got {self.per_bay}")
        if not 0.0 < self.gap[0] <= self.gap[1]:
            raise ConfigError(f"clutter gap must be 0 < low <= high, got {self.gap}")


def clutter_name(kind: str, j: int) -> str:
    """Body (and geom) name of clutter object ``j`` (0-based) of ``kind``."""
    return f"clutter_{kind}_{j}"
