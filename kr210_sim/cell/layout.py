"""The cell's layout as the compiled model holds it: the one source of truth at run time.

Slots, the shelf's volume, the bin's inside and the drop spots are named sites of the model
(``slot_<n>``, ``shelf_box``, ``bin_inside``, ``drop_<n>``; see :mod:`kr210_sim.cell.mjcf`), the
nominal target is ``target_0``, and the cell's name, hash and randomisation ranges are custom
model data. Whatever model is simulated, ``--scene`` or ``--cell``, is planned against and scored
against: nothing here reads :mod:`kr210_sim.cell.spec`'s copy of a cell.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from kr210_sim.cell.spec import RandomizationSpec, TargetSpec
from kr210_sim.errors import SceneError

import mujoco  # isort: skip

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class BinBox:
    """The inside of the bin.

    Attributes:
        center: Centre of the footprint (x, y) [m].
        inner_half: Half the inner extents (x, y) [m].
        floor_top: z of the bin floor's top [m].
        rim: z of the rim [m].
    """

    center: tuple[float, float]
    inner_half: tuple[float, float]
    floor_top: float
    rim: float


@dataclass(frozen=True, slots=True)
class ShelfBox:
    """The shelf's outer volume.

    Attributes:
        center: Centre [m].
        R: Rotation of the shelf frame (x from the open front into the shelf).
        half: Half extents in the shelf frame [m].
    """

    center: FloatArray
    R: FloatArray
    half: FloatArray

    def local(self, point: npt.ArrayLike) -> FloatArray:
        """``point`` [m] in the shelf frame, relative to the centre."""
        return self.R.T @ (np.asarray(point, dtype=np.float64) - self.center)


@dataclass(frozen=True, slots=True)
class CellLayout:
    """What the runner, planner and scoring need of the cell, read from a compiled model.

    Attributes:
        name: The cell's name ("unnamed" for a scene without one).
        sha256: Hash of the cell file the model was built from ("none" if unknown).
        layout_sha256: Hash of the figures below (slots, shelf, bin, drop spots), as read.
        slots: Each slot's point on its board [m], shape (n, 3); slot n is row n - 1.
        shelf: The shelf's outer volume.
        bin: The bin's inside.
        drop_spots: Release points (x, y) [m], shape (m, 2), used in turn.
        target: The nominal target (``target_0`` as compiled).
        randomization: Randomisation ranges.
        park: Where each spare target waits (its initial position) [m], shape (k, 3).
        ready_q: The cell's ready pose [rad], shape (6,), or None (the motion settings' one).
    """

    name: str
    sha256: str
    layout_sha256: str
    slots: FloatArray
    shelf: ShelfBox
    bin: BinBox
    drop_spots: FloatArray
    target: TargetSpec
    randomization: RandomizationSpec
    park: FloatArray
    ready_q: FloatArray | None = None

    @property
    def n_slots(self) -> int:
        """Number of slots."""
        return len(self.slots)

    def describe(self) -> dict[str, object]:
        """The report's record of the cell."""
        return {
            "name": self.name,
            "sha256": self.sha256,
            "layout_sha256": self.layout_sha256,
            "slots": self.n_slots,
            "bin_center": [round(float(v), 6) for v in self.bin.center],
            "randomization": {
                "xy_offset": self.randomization.xy_offset,
                "yaw": list(self.randomization.yaw),
                "radius": list(self.randomization.radius),
                "length": list(self.randomization.length),
                "mass": list(self.randomization.mass),
                "friction": list(self.randomization.friction),
            },
        }

    @classmethod
    def from_model(cls, model: mujoco.MjModel) -> CellLayout:
        """Read the layout from a compiled cell model.

        Raises:
            SceneError: When a site the layout needs is missing.
        """
        data = mujoco.MjData(model)
        mujoco.mj_kinematics(model, data)

        def site(name: str) -> int:
            i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, name)
            if i < 0:
                raise SceneError(
                    f"scene is not a kr210_sim cell: it has no site {name!r} (rebuild it from a "
                    "cell file: python -m kr210_sim build-scene, or run with --cell)"
                )
            return int(i)

        def numbered(prefix: str) -> list[int]:
            out, n = [], 1
            while mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, f"{prefix}_{n}") >= 0:
                out.append(site(f"{prefix}_{n}"))
                n += 1
            if not out:
                site(f"{prefix}_1")  # raises
            return out

        slots = np.array([data.site_xpos[i] for i in numbered("slot")])
        drops = np.array([data.site_xpos[i][:2] for i in numbered("drop")])
        sb = site("shelf_box")
        shelf = ShelfBox(
            data.site_xpos[sb].copy(),
            data.site_xmat[sb].reshape(3, 3).copy(),
            model.site_size[sb].copy(),
        )
        bi = site("bin_inside")
        c, half = data.site_xpos[bi], model.site_size[bi]
        bin_box = BinBox(
            (float(c[0]), float(c[1])),
            (float(half[0]), float(half[1])),
            float(c[2] - half[2]),
            float(c[2] + half[2]),
        )
        tb = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "target_0")
        tg = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "target_0")
        if tb < 0 or tg < 0:
            raise SceneError("scene has no target cylinders (target_0 ...)")
        target = TargetSpec(
            radius=float(model.geom_size[tg, 0]),
            length=float(2.0 * model.geom_size[tg, 1]),
            mass=float(model.body_mass[tb]),
            friction=float(model.geom_friction[tg, 0]),
        )
        park = []
        k = 0
        while True:
            j = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, f"target_{k}_joint")
            if j < 0:
                break
            a = model.jnt_qposadr[j]
            park.append(model.qpos0[a : a + 3].copy())
            k += 1
        bin_figures = np.array(
            [*bin_box.center, *bin_box.inner_half, bin_box.floor_top, bin_box.rim]
        )
        parts = [
            slots.ravel(),
            shelf.center,
            shelf.R.ravel(),
            shelf.half,
            drops.ravel(),
            bin_figures,
        ]
        figures = np.concatenate(parts)
        layout_hash = hashlib.sha256(np.round(figures, 6).tobytes()).hexdigest()
        return cls(
            name=_shown(_text(model, "cell_name", "unnamed")),
            sha256=_text(model, "cell_sha256", "none"),
            layout_sha256=layout_hash,
            slots=slots,
            shelf=shelf,
            bin=bin_box,
            drop_spots=drops,
            target=target,
            randomization=_randomization(model),
            park=np.array(park),
            ready_q=ready_q_of(model),
        )


def ready_q_of(model: mujoco.MjModel) -> FloatArray | None:
    """The ready pose a cell model sets (numeric ``ready_q_deg``) [rad], or None."""
    i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_NUMERIC, "ready_q_deg")
    if i < 0 or model.numeric_size[i] != 6:
        return None
    adr = model.numeric_adr[i]
    return np.radians(np.array(model.numeric_data[adr : adr + 6], dtype=np.float64))


def ready_pose(model: mujoco.MjModel) -> FloatArray:
    """The ready pose of a cell model [rad]: the cell's own (``[robot] ready_q``) when it sets
    one, else the motion settings' default, as configured (a planner with a collision checker
    uses the clear pose nearest it when it collides, :class:`~kr210_sim.plan.planner.Planner`)."""
    from kr210_sim.cell.spec import MotionConfig

    q = ready_q_of(model)
    return q if q is not None else np.array(MotionConfig().ready_q, dtype=np.float64)


#: Longest cell name shown in tables and reports [characters] (cell files allow no longer).
MAX_NAME = 64


def _shown(name: str) -> str:
    """A scene's cell name as tables show it: control characters escaped, at most
    :data:`MAX_NAME` characters (a hand-made scene's newline or 50 MB name broke the table)."""
    if not name.isprintable():
        name = name.encode("unicode_escape").decode("ascii")
    return name if len(name) <= MAX_NAME else name[: MAX_NAME - 3] + "..."


def _text(model: mujoco.MjModel, name: str, default: str) -> str:
    i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_TEXT, name)
    if i < 0:
        return default
    adr, n = model.text_adr[i], model.text_size[i]
    return bytes(model.text_data[adr : adr + n - 1]).decode(errors="replace")


def _randomization(model: mujoco.MjModel) -> RandomizationSpec:
    """The ranges stored in the model (``randomize_*`` numerics), defaults where missing."""
    d = RandomizationSpec()

    def get(key: str, n: int) -> tuple[float, ...] | None:
        i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_NUMERIC, f"randomize_{key}")
        if i < 0 or model.numeric_size[i] != n:
            return None
        adr = model.numeric_adr[i]
        return tuple(float(v) for v in model.numeric_data[adr : adr + n])

    xy = get("xy_offset", 1)
    ranges = {k: get(k, 2) or getattr(d, k) for k in ("radius", "length", "mass", "friction")}
    yaw_deg = get("yaw_deg", 2)
    ranges["yaw"] = tuple(np.radians(yaw_deg).tolist()) if yaw_deg else d.yaw
    return RandomizationSpec(xy_offset=xy[0] if xy else d.xy_offset, **ranges)  # type: ignore[arg-type]
