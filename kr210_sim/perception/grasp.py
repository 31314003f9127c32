"""A grasp for the target that clears its neighbours, or why none does.

The gripper is a two-finger parallel gripper that approaches level, from the robot's side, along
a heading (as :func:`kr210_sim.plan.poses.pick_poses` plans it): radial first, then further off
the radial to either side. In the frame of a heading (u along the approach, w across it, the
target's axis at the origin), the open fingers sweep the corridor ``|w| <= gap / 2 + finger``
from the robot up to their tips, which end :attr:`GripperEnvelope.tip_past_axis` beyond the
target's axis, over the fingers' height around the grasp. A heading clears when no point of
another object, nor of the bay's posts, lies in that corridor.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]

#: Headings tried off the radial [deg], nearest first (the planner's GRASP_HEADINGS and 0).
HEADINGS_DEG = (0, *(s * d for d in range(5, 50, 5) for s in (1, -1)))


@dataclass(frozen=True, slots=True)
class GripperEnvelope:
    """What the open gripper sweeps.

    Attributes:
        open_gap: Distance between the open fingers' inner faces [m].
        finger: Thickness of a finger across the approach [m].
        tip_past_axis: How far the fingertips reach past the target's axis at the grasp [m].
        half_height: Half the fingers' height [m].
        margin: Clearance kept to anything in the corridor [m].
    """

    open_gap: float = 0.179
    finger: float = 0.02
    tip_past_axis: float = 0.06
    half_height: float = 0.03
    margin: float = 0.01


@dataclass(frozen=True)
class Grasp:
    """A grasp that clears.

    Attributes:
        yaw: The gripper's heading [rad] (the approach direction in the base frame's xy).
        offset_deg: Its angle off the radial [deg].
        clearance: Distance from the corridor's edge to the nearest obstacle point [m].
    """

    yaw: float
    offset_deg: float
    clearance: float


def choose_grasp(
    target: npt.ArrayLike,
    obstacles: FloatArray,
    owners: tuple[str, ...] | list[str],
    owner_index: npt.NDArray[np.intp],
    grasp_dz: float = 0.0,
    envelope: GripperEnvelope | None = None,
) -> tuple[Grasp | None, str]:
    """The heading nearest the radial whose corridor is clear.

    Args:
        target: The target's centre in the base frame [m].
        obstacles: (M, 3) points of the other objects and of the bay's posts [m].
        owners: The names of what the points belong to.
        owner_index: (M,) each point's index into ``owners``.
        grasp_dz: Height of the fingers' centre above the target's centre [m].
        envelope: The gripper (the KR210's by default).

    Returns:
        The grasp, or None and why none clears (what blocks each heading).
    """
    env = envelope or GripperEnvelope()
    p = np.asarray(target, dtype=np.float64)
    radial = math.atan2(p[1], p[0])
    rel = obstacles - p
    zc = grasp_dz
    in_height = np.abs(rel[:, 2] - zc) <= env.half_height + env.margin
    rel = rel[in_height]
    idx = np.asarray(owner_index)[in_height]
    half_width = env.open_gap / 2.0 + env.finger + env.margin
    blockers: dict[str, int] = {}
    for off in HEADINGS_DEG:
        yaw = radial + math.radians(off)
        u = rel[:, 0] * math.cos(yaw) + rel[:, 1] * math.sin(yaw)
        w = -rel[:, 0] * math.sin(yaw) + rel[:, 1] * math.cos(yaw)
        ahead = u <= env.tip_past_axis + env.margin
        inside = ahead & (np.abs(w) <= half_width)
        if not np.any(inside):
            clear = np.abs(w[ahead]) - half_width
            clearance = float(clear.min()) if clear.size else math.inf
            return Grasp(yaw, float(off), clearance), ""
        for k in np.unique(idx[inside]):
            blockers[owners[int(k)]] = blockers.get(owners[int(k)], 0) + 1
    names = ", ".join(f"{n} ({c} headings)" for n, c in sorted(blockers.items()))
    return None, f"no heading within 45 deg of the radial clears: blocked by {names}"
