"""The free parts of a cell (targets and clutter) in the MJCF: one body, one geom, the same
contact settings (used by :mod:`kr210_sim.cell.mjcf` and :mod:`kr210_sim.cell.sensing_mjcf`)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from kr210_sim.cell.robot_model import GRASP_SOLIMP, GRASP_SOLREF, TARGET_AFFINITY, TARGET_BIT

import mujoco  # isort: skip  (after kr210_sim so MUJOCO_GL is chosen first)

#: Coefficient of rolling friction of steel on steel, as a length [m] (MuJoCo's rolling
#: friction: the largest rolling torque is this times the normal force): 0.02 in = 0.5 mm,
#: "iron on iron" in eMachineShop's table of rolling friction (emachineshop.com/rolling-friction),
#: 0.5 mm "steel wheels on steel rails" in the Engineering ToolBox's
#: (engineeringtoolbox.com/rolling-friction-resistance-d_1303.html). The target cylinders are
#: steel, and so are the bin's walls.
STEEL_ROLLING = 0.0005
#: Torsional friction of the parts' contacts [m] (the largest torque about the contact normal
#: is this times the normal force).
PART_TORSION = 0.01


def add_free_part(
    spec: mujoco.MjSpec,
    name: str,
    position: npt.ArrayLike,
    geom_type: mujoco.mjtGeom,
    size: Sequence[float],
    mass: float,
    rgba: Sequence[float],
    friction: float,
) -> mujoco.MjsBody:
    """A free body ``name`` at ``position`` [m] (asleep until touched) with one geom of the
    same name: a part's contacts (``TARGET_BIT``), its sliding ``friction`` and steel's
    torsional and rolling friction.

    Returns:
        The body.
    """
    pos = [float(v) for v in np.asarray(position, dtype=np.float64)]
    body = spec.worldbody.add_body(name=name, pos=pos)
    body.sleep = mujoco.mjtSleepPolicy.mjSLEEP_INIT
    body.add_freejoint(name=f"{name}_joint")
    body.add_geom(
        name=name,
        type=geom_type,
        size=list(size),
        mass=mass,
        rgba=list(rgba),
        contype=TARGET_BIT,
        conaffinity=TARGET_AFFINITY,
        # condim 6: rolling and torsional resistance in every contact whose parameters are
        # the parts' (the higher priority): on another part, a wall, a finger pad, so a
        # cylinder on a pile stops rolling instead of shifting for seconds.
        condim=6,
        friction=[friction, PART_TORSION, STEEL_ROLLING],
        priority=1,
        solref=list(GRASP_SOLREF),
        solimp=list(GRASP_SOLIMP),
    )
    return body
