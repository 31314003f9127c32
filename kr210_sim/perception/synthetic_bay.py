"""Seeded cluttered bays for the ray caster (:mod:`kr210_sim.perception.synthetic`).

A bay of the published shelf's proportions (boards, posts, back panel) holding a target and a few
distractors standing on the board with small gaps, and the cameras that look at it: the fixed
sensor's viewpoint (2.3 m in front of the shelf, 0.6 m to the side, above the bay) and a wrist
camera's close look. Tests and benchmarks use it where no renderer is wanted.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from kr210_sim.perception.cloud import BayBox
from kr210_sim.perception.kinds import Kind
from kr210_sim.perception.synthetic import Primitive, look_at

FloatArray = npt.NDArray[np.float64]

#: Thickness of the boards, width of the posts and thickness of the back panel [m].
BOARD, POST, BACK = 0.04, 0.1, 0.02
#: The shelf's colour.
SHELF_RGB = (0.58, 0.6, 0.62)

#: Kinds like a cluttered cell's: the blue target, and distractors of other colours, sizes
#: and shapes.
DEFAULT_KINDS = (
    Kind("target", "cylinder", (0.05, 0.25), (0.1, 0.35, 0.95)),
    Kind("red_can", "cylinder", (0.035, 0.15), (0.85, 0.12, 0.1)),
    Kind("green_tube", "cylinder", (0.045, 0.3), (0.15, 0.7, 0.2)),
    Kind("crate", "box", (0.1, 0.14, 0.2), (0.85, 0.6, 0.2)),
    Kind("brick", "box", (0.08, 0.08, 0.12), (0.6, 0.2, 0.6)),
    Kind("ball", "sphere", (0.05,), (0.95, 0.85, 0.1)),
)

#: The published cell's middle bay, as a box.
DEFAULT_BAY = BayBox(centre=(2.69, 0.0, 1.1725), yaw=0.0, half=(0.2, 0.4, 0.3635))


@dataclass(frozen=True)
class Truth:
    """Where an object of a synthetic bay stands.

    Attributes:
        label: Its kind's name.
        shape: Its kind's shape.
        position: Its centre in the base frame [m].
        yaw: Its rotation about z [rad].
        size: Its size as :class:`~kr210_sim.perception.kinds.Kind` gives it [m].
    """

    label: str
    shape: str
    position: FloatArray
    yaw: float
    size: tuple[float, ...]


def shelf_primitives(box: BayBox) -> list[Primitive]:
    """The board under the bay and above it, the two posts and the back panel."""
    hx, hy, hz = box.half
    parts = [
        ((0.0, 0.0, -hz - BOARD / 2), (hx + BACK, hy + POST, BOARD / 2)),
        ((0.0, 0.0, hz + BOARD / 2), (hx + BACK, hy + POST, BOARD / 2)),
        ((0.0, -hy - POST / 2, 0.0), (hx + BACK, POST / 2, hz)),
        ((0.0, hy + POST / 2, 0.0), (hx + BACK, POST / 2, hz)),
        ((hx + BACK / 2, 0.0, 0.0), (BACK / 2, hy, hz)),
    ]
    out = []
    for c, h in parts:
        centre = box.to_base(np.asarray(c))
        out.append(Primitive("box", tuple(centre), h, SHELF_RGB, yaw=box.yaw))
    return out


def _footprint(kind: Kind) -> float:
    """Radius of the disc holding the kind's footprint at any yaw [m]."""
    if kind.shape == "box":
        return 0.5 * math.hypot(kind.size[0], kind.size[1])
    return kind.size[0]


def _primitive(kind: Kind, local: FloatArray, yaw: float, box: BayBox) -> Primitive:
    """The kind's solid at bay-local ``local`` (x, y on the board) turned by ``yaw`` [rad]."""
    z = -box.half[2] + kind.height / 2.0
    centre = box.to_base(np.array([local[0], local[1], z]))
    if kind.shape == "cylinder":
        size: tuple[float, ...] = (kind.size[0], kind.size[1] / 2.0)
    elif kind.shape == "box":
        size = tuple(s / 2.0 for s in kind.size)
    else:
        size = kind.size
    return Primitive(kind.shape, tuple(centre), size, kind.rgb, yaw=yaw + box.yaw, label=kind.name)


def clutter(
    rng: np.random.Generator,
    box: BayBox,
    target: Kind,
    distractors: list[Kind],
    gap: tuple[float, float] = (0.002, 0.03),
) -> tuple[list[Primitive], list[Truth]]:
    """The target near the bay's slot and each distractor beside one already placed.

    Args:
        rng: The draw's generator.
        box: The bay.
        target: The kind to pick (placed first, 0.11 m behind the front, +-0.15 m across).
        distractors: The others, placed in turn at a gap from a random earlier object (a kind
            that finds no room after 200 tries is left out).
        gap: Smallest and largest gap between footprints [m].

    Returns:
        The objects' solids (the shelf's not included) and where each stands.
    """
    hx, hy, _ = box.half
    placed: list[tuple[Kind, FloatArray, float]] = []

    def fits(kind: Kind, xy: FloatArray) -> bool:
        r = _footprint(kind)
        if abs(xy[0]) > hx - r - 0.01 or abs(xy[1]) > hy - r - 0.01:
            return False
        return all(np.hypot(*(xy - p)) >= r + _footprint(k) + gap[0] for k, p, _ in placed)

    first = np.array([-hx + 0.11 + rng.uniform(0.0, 0.04), rng.uniform(-0.15, 0.15)])
    placed.append((target, first, float(rng.uniform(-math.pi, math.pi))))
    for kind in distractors:
        for _ in range(200):
            anchor_kind, anchor, _ = placed[int(rng.integers(len(placed)))]
            d = _footprint(kind) + _footprint(anchor_kind) + rng.uniform(*gap)
            a = rng.uniform(-math.pi, math.pi)
            xy = anchor + d * np.array([math.cos(a), math.sin(a)])
            if fits(kind, xy):
                placed.append((kind, xy, float(rng.uniform(-math.pi, math.pi))))
                break
    prims = [_primitive(k, xy, yaw, box) for k, xy, yaw in placed]
    truths = [
        Truth(k.name, k.shape, np.asarray(p.centre), p.yaw, k.size)
        for (k, _, _), p in zip(placed, prims, strict=True)
    ]
    return prims, truths


def fixed_camera(box: BayBox) -> FloatArray:
    """The fixed sensor's optical frame for ``box``: 2.3 m in front of the shelf's front,
    0.6 m to the right as the robot sees it, 0.7 m above the bay's centre, looking at it."""
    hx = box.half[0]
    eye = box.to_base(np.array([-hx - 2.3 - 0.02, -0.6, 0.7]))
    return look_at(eye, box.centre)


def wrist_camera(box: BayBox, target: npt.ArrayLike, distance: float = 0.55) -> FloatArray:
    """A close look at ``target`` [m] from the robot's side: ``distance`` [m] in front of it
    along the bay's x, 0.15 m higher."""
    t = np.asarray(target, dtype=np.float64)
    R = box.rotation
    eye = t - distance * R[:, 0] + np.array([0.0, 0.0, 0.15])
    return look_at(eye, t)
