"""The cell's sensors, object kinds, clutter settings and pick list as the compiled model holds
them (written by :mod:`kr210_sim.cell.sensing_mjcf`): at run time the model is the source of
truth, as for the rest of the layout (:mod:`kr210_sim.cell.layout`).

A scene built before sensors existed (or by hand) has none of this data: it has no sensors, no
object kinds, no clutter, and its pick list is the target.
"""

from __future__ import annotations

import numpy as np

from kr210_sim.cell.layout import _text
from kr210_sim.cell.sensing import (
    SHAPES,
    SIZE_FIGURES,
    TARGET_KIND,
    ClutterSpec,
    ObjectKind,
    SensorSpec,
)
from kr210_sim.errors import SceneError

import mujoco  # isort: skip


def _numeric(model: mujoco.MjModel, name: str) -> np.ndarray | None:
    i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_NUMERIC, name)
    if i < 0:
        return None
    adr, n = model.numeric_adr[i], model.numeric_size[i]
    return np.array(model.numeric_data[adr : adr + n], dtype=np.float64)


def _names(model: mujoco.MjModel, text: str) -> tuple[str, ...]:
    return tuple(_text(model, text, "").split())


def sensors_of(model: mujoco.MjModel) -> dict[str, SensorSpec]:
    """The model's sensors by name, as declared (pose as the model's camera holds it).

    Raises:
        SceneError: When a listed sensor's camera or data is missing.
    """
    out: dict[str, SensorSpec] = {}
    for name in _names(model, "sensors"):
        cam = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, name)
        figures = _numeric(model, f"sensor_{name}")
        if cam < 0 or figures is None or len(figures) != 5:
            raise SceneError(f"sensor {name!r} has no camera or no figures in the model")
        # the camera's pose in its body's frame, as an optical-frame quaternion
        q = np.array(model.cam_quat[cam], dtype=np.float64)
        R_mj = np.zeros(9)
        mujoco.mju_quat2Mat(R_mj, q)
        R = R_mj.reshape(3, 3) @ np.diag([1.0, -1.0, -1.0])
        q_opt = np.zeros(4)
        mujoco.mju_mat2Quat(q_opt, R.ravel())
        near, far, seed, w, h = figures
        out[name] = SensorSpec(
            name=name,
            mount=_text(model, f"sensor_{name}_mount", "world"),
            position=tuple(float(v) for v in model.cam_pos[cam]),  # type: ignore[arg-type]
            look_at=None,
            quaternion=tuple(float(v) for v in q_opt),  # type: ignore[arg-type]
            resolution=(int(w), int(h)),
            fovy_deg=float(model.cam_fovy[cam]),
            near=float(near),
            far=float(far),
            noise=_text(model, f"sensor_{name}_noise", "none"),
            seed=int(seed),
        )
    return out


def kinds_of(model: mujoco.MjModel) -> tuple[ObjectKind, ...]:
    """The model's object kinds, in the cell file's order."""
    out = []
    for name in _names(model, "object_kinds"):
        f = _numeric(model, f"object_{name}")
        if f is None or len(f) != 10:
            raise SceneError(f"object kind {name!r} has no figures in the model")
        shape = SHAPES[int(f[0])]
        out.append(
            ObjectKind(
                name=name,
                shape=shape,
                size=tuple(float(v) for v in f[1 : 1 + SIZE_FIGURES[shape]]),
                rgb=(float(f[4]), float(f[5]), float(f[6])),
                mass=float(f[7]),
                friction=float(f[8]),
                count=int(f[9]),
            )
        )
    return tuple(out)


def clutter_of(model: mujoco.MjModel) -> ClutterSpec | None:
    """The model's clutter settings, or None for a tidy shelf."""
    f = _numeric(model, "clutter")
    if f is None or len(f) != 5:
        return None
    return ClutterSpec(
        per_bay=(int(f[0]), int(f[1])), gap=(float(f[2]), float(f[3])), seed=int(f[4])
    )


def pick_list_of(model: mujoco.MjModel) -> tuple[str, ...]:
    """The kinds picked in turn, cycle after cycle (``("target",)`` when the cell sets none)."""
    return _names(model, "pick_list") or (TARGET_KIND,)
