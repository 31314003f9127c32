"""The kinds of object the pipeline tells apart, and what it says about each one it sees.

A :class:`Kind` holds what a cell file says of an object kind (any object with ``name``,
``shape``, ``size`` and ``rgb`` attributes converts with :meth:`Kind.of`): the pipeline uses the
shape to choose a fit and the nominal size to check it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]

#: The shapes the pipeline fits.
SHAPES = ("cylinder", "box", "sphere")
#: Size figures per shape: cylinder (radius, length), box full extents (x, y, z), sphere (radius,).
SIZE_FIGURES = {"cylinder": 2, "box": 3, "sphere": 1}


@dataclass(frozen=True, slots=True)
class Kind:
    """An object kind.

    Attributes:
        name: The kind's label.
        shape: "cylinder" (upright), "box" or "sphere".
        size: cylinder (radius, length), box full extents (x, y, z), sphere (radius,) [m].
        rgb: Colour, each channel in [0, 1].
    """

    name: str
    shape: str
    size: tuple[float, ...]
    rgb: tuple[float, float, float]

    def __post_init__(self) -> None:
        if self.shape not in SHAPES:
            raise ValueError(f"kind {self.name!r}: shape must be one of {SHAPES}")
        if len(self.size) != SIZE_FIGURES[self.shape]:
            raise ValueError(
                f"kind {self.name!r}: a {self.shape} takes {SIZE_FIGURES[self.shape]} sizes"
            )

    @classmethod
    def of(cls, obj: object) -> Kind:
        """A :class:`Kind` from any object with ``name``, ``shape``, ``size`` and ``rgb``."""
        if isinstance(obj, Kind):
            return obj
        size = tuple(float(s) for s in getattr(obj, "size"))  # noqa: B009
        rgb = tuple(float(c) for c in getattr(obj, "rgb"))[:3]  # noqa: B009
        return cls(str(getattr(obj, "name")), str(getattr(obj, "shape")), size, rgb)  # type: ignore[arg-type]  # noqa: B009

    @property
    def height(self) -> float:
        """Height standing upright [m]."""
        if self.shape == "cylinder":
            return self.size[1]
        if self.shape == "box":
            return self.size[2]
        return 2.0 * self.size[0]


@dataclass(frozen=True)
class Pose:
    """An object's fitted pose in the base frame.

    Attributes:
        position: Centre [m].
        axis: Unit axis (a cylinder's, a box's z; a sphere's is z).
        frame: 3 x 3 rotation: a box's edges' directions as columns (x, y, z), a cylinder's
            axis as its z.
        size: Fitted size, as :class:`Kind` gives it [m].
        residual: RMS distance of the cluster's points to the fitted surface [m].
    """

    position: FloatArray
    axis: FloatArray
    frame: FloatArray
    size: tuple[float, ...]
    residual: float


@dataclass(frozen=True)
class Detection:
    """One cluster seen, recognised and fitted.

    Attributes:
        label: The kind recognised ("" when none was).
        confidence: The classifier's probability for ``label``, lowered when the fit disagrees
            with the kind's size, in [0, 1].
        shape: The recognised kind's shape.
        pose: The fitted pose (None when the fit failed).
        n_points: Points in the cluster.
        centroid: The cluster's centroid [m] in the base frame.
        notes: Why the confidence is low, when it is.
        measured: Whether the fit measured the object's size (else the kind's was used: a far
            look, whose pose is only as good as the kind's nominal size).
    """

    label: str
    confidence: float
    shape: str
    pose: Pose | None
    n_points: int
    centroid: FloatArray
    notes: tuple[str, ...] = field(default_factory=tuple)
    measured: bool = True
