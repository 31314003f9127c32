"""The truth about what stands on the shelf, for scoring: every object's label, pose and size,
read from the simulation (never given to a perception pipeline).

Targets (``target_<k>``) are labelled by their colour: the pick kinds have colours of their own,
none the target's (:mod:`kr210_sim.cell.sensing_toml` checks it), and a target made for a kind
wears the kind's colour (:meth:`kr210_sim.sim.clutter.Clutter.scatter`). Distractors
(``clutter_<kind>_<j>``) carry their kind in their name.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from kr210_sim.cell.layout import CellLayout
from kr210_sim.cell.sensing import TARGET_KIND, ObjectKind
from kr210_sim.cell.sensing_layout import kinds_of, pick_list_of

import mujoco  # isort: skip

FloatArray = npt.NDArray[np.float64]
#: How far outside the shelf's outer volume an object still counts as on it [m].
SHELF_MARGIN = 0.05
_SHAPES = {
    int(mujoco.mjtGeom.mjGEOM_CYLINDER): "cylinder",
    int(mujoco.mjtGeom.mjGEOM_BOX): "box",
    int(mujoco.mjtGeom.mjGEOM_SPHERE): "sphere",
}


@dataclass(frozen=True, slots=True)
class TruthObject:
    """One object on the shelf as the simulation holds it.

    Attributes:
        label: Its kind's name ("target" for the cell's own target cylinder).
        body: Its body id.
        geom: Its geom id (what a segmentation render shows).
        shape: "cylinder", "box" or "sphere".
        size: cylinder (radius, length), box full extents (x, y, z), sphere (radius,) [m].
        position: Its centre in the base frame [m].
        R: Its orientation in the base frame (a cylinder's axis is the third column).
        is_target: Whether it is a target cylinder (one the pick list may name).
    """

    label: str
    body: int
    geom: int
    shape: str
    size: tuple[float, ...]
    position: FloatArray
    R: FloatArray
    is_target: bool

    @property
    def T_base_object(self) -> FloatArray:
        """Its pose as a 4 x 4 transform in the base frame [m]."""
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = self.R, self.position
        return T


def _size(shape: str, half: npt.NDArray[np.float64]) -> tuple[float, ...]:
    if shape == "cylinder":
        return (float(half[0]), float(2.0 * half[1]))
    if shape == "box":
        return tuple(float(2.0 * v) for v in half)
    return (float(half[0]),)


def target_label(rgba: npt.ArrayLike, kinds: tuple[ObjectKind, ...], picks: tuple[str, ...]) -> str:
    """The pick kind a target cylinder wears, by its colour ("target" when no pick kind's
    matches: the cell's own target)."""
    rgb = np.asarray(rgba, dtype=np.float64)[:3]
    for k in kinds:
        if k.name in picks and np.allclose(rgb, k.rgb, atol=1e-4):
            return k.name
    return TARGET_KIND


def shelf_truth(
    model: mujoco.MjModel, data: mujoco.MjData, layout: CellLayout | None = None
) -> list[TruthObject]:
    """Every target and distractor on the shelf now (within :data:`SHELF_MARGIN` of its outer
    volume), in body order.

    Args:
        model: The cell model.
        data: Its state (after kinematics).
        layout: The cell's layout (default: read from ``model``).
    """
    layout = layout if layout is not None else CellLayout.from_model(model)
    kinds, picks = kinds_of(model), pick_list_of(model)
    half = layout.shelf.half + SHELF_MARGIN
    out = []
    for g in range(model.ngeom):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or ""
        is_target = name.startswith("target_")
        if not (is_target or name.startswith("clutter_")):
            continue
        shape = _SHAPES.get(int(model.geom_type[g]))
        if shape is None:
            continue
        b = int(model.geom_bodyid[g])
        pos = data.xpos[b].copy()
        if np.any(np.abs(layout.shelf.local(pos)) > half):
            continue
        if is_target:
            label = target_label(model.geom_rgba[g], kinds, picks)
        else:
            label = name[len("clutter_") :].rsplit("_", 1)[0]
        out.append(
            TruthObject(
                label=label,
                body=b,
                geom=g,
                shape=shape,
                size=_size(shape, model.geom_size[g]),
                position=pos,
                R=data.xmat[b].reshape(3, 3).copy(),
                is_target=is_target,
            )
        )
    return out
